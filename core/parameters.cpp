#include "core/parameters.hpp"

#include <cassert>
#include <stdexcept>
#include <variant>

namespace twill {
namespace {

void append_curve_flat(const Curve& c, Eigen::VectorXd& flat, int& at) {
  for (int i = 1; i < c.degree(); ++i) flat[at++] = c.mu[static_cast<size_t>(i)];
  for (int i = 0; i < c.degree(); ++i) flat[at++] = c.alpha[static_cast<size_t>(i)];
}

void read_curve_flat(Curve& c, const Eigen::VectorXd& flat, int& at) {
  double rest = 0.0;
  for (int i = 1; i < c.degree(); ++i) {
    c.mu[static_cast<size_t>(i)] = flat[at++];
    rest += c.mu[static_cast<size_t>(i)];
  }
  c.mu[0] = 1.0 - rest;  // Σμ = 1 by construction (paper §3.1)
  for (int i = 0; i < c.degree(); ++i) c.alpha[static_cast<size_t>(i)] = flat[at++];
}

void append_curve_names(const std::string& name, const Curve& c, std::vector<std::string>& out) {
  for (int i = 1; i < c.degree(); ++i) out.push_back(name + ".mu[" + std::to_string(i) + "]");
  for (int i = 0; i < c.degree(); ++i) out.push_back(name + ".alpha[" + std::to_string(i) + "]");
}

// Calls visit(name, value) for every effect parameter (double options, flat order).
template <class Effects, class Visit>
void for_each_effect_parameter(Effects& effects, Visit visit) {
  for (auto& effect : effects)
    for (auto& entry : effect.options.entries())
      if (std::holds_alternative<double>(entry.value)) visit(effect.name + "." + entry.key, effect, entry.key);
}

int count_effect_parameters(const std::vector<ComponentChoice>& effects) {
  int n = 0;
  for_each_effect_parameter(effects, [&n](const std::string&, const ComponentChoice&, const std::string&) { ++n; });
  return n;
}

}  // namespace

FlatLayout::FlatLayout(const MaterialParameters& p) {
  eta1 = kFirstCurve;
  eta3 = eta1 + 2 * p.eta1.degree() - 1;
  eta4 = eta3 + 2 * p.eta3.degree() - 1;
  eta2 = eta4 + 2 * p.eta4.degree() - 1;
  bending = eta2 + 2 * p.eta2.degree() - 1;
  effects = bending + kBendingRatios;
  size = effects + count_effect_parameters(p.effects);
}

int MaterialParameters::flat_size() const { return FlatLayout(*this).size; }

Eigen::VectorXd MaterialParameters::to_flat() const {
  Eigen::VectorXd flat(flat_size());
  flat[FlatLayout::kDensity] = density_kg_m2;
  flat[FlatLayout::kThickness] = thickness_m;
  flat[FlatLayout::kA11] = a11_Pa;
  flat[FlatLayout::kA12] = a12_Pa;
  flat[FlatLayout::kA22] = a22_Pa;
  flat[FlatLayout::kG12] = G12_Pa;
  int at = FlatLayout::kFirstCurve;
  append_curve_flat(eta1, flat, at);
  append_curve_flat(eta3, flat, at);
  append_curve_flat(eta4, flat, at);
  append_curve_flat(eta2, flat, at);
  flat[at++] = bending_warp_ratio;
  flat[at++] = bending_weft_ratio;
  for_each_effect_parameter(effects, [&](const std::string&, const ComponentChoice& effect, const std::string& key) {
    flat[at++] = effect.options.get_double(key);
  });
  assert(at == flat.size());
  return flat;
}

void MaterialParameters::set_from_flat(const Eigen::VectorXd& flat) {
  if (flat.size() != flat_size())
    throw std::invalid_argument("MaterialParameters::set_from_flat: vector has " +
                                std::to_string(flat.size()) + " entries, the layout needs " +
                                std::to_string(flat_size()));
  density_kg_m2 = flat[FlatLayout::kDensity];
  thickness_m = flat[FlatLayout::kThickness];
  a11_Pa = flat[FlatLayout::kA11];
  a12_Pa = flat[FlatLayout::kA12];
  a22_Pa = flat[FlatLayout::kA22];
  G12_Pa = flat[FlatLayout::kG12];
  int at = FlatLayout::kFirstCurve;
  read_curve_flat(eta1, flat, at);
  read_curve_flat(eta3, flat, at);
  read_curve_flat(eta4, flat, at);
  read_curve_flat(eta2, flat, at);
  bending_warp_ratio = flat[at++];
  bending_weft_ratio = flat[at++];
  for (ComponentChoice& effect : effects)
    for (const OptionEntry& entry : effect.options.entries())
      if (std::holds_alternative<double>(entry.value)) effect.options.set(entry.key, flat[at++]);
}

std::vector<std::string> MaterialParameters::parameter_names() const {
  std::vector<std::string> names = {"density_kg_m2", "thickness_m", "a11_Pa",
                                    "a12_Pa",        "a22_Pa",      "G12_Pa"};
  append_curve_names("eta1", eta1, names);
  append_curve_names("eta3", eta3, names);
  append_curve_names("eta4", eta4, names);
  append_curve_names("eta2", eta2, names);
  names.insert(names.end(), {kBendingWarpRatioName, kBendingWeftRatioName});
  for_each_effect_parameter(effects, [&names](const std::string& name, const ComponentChoice&, const std::string&) {
    names.push_back(name);
  });
  return names;
}

int MaterialParameters::index_of(const std::string& name) const {
  const auto names = parameter_names();
  for (size_t i = 0; i < names.size(); ++i)
    if (names[i] == name) return static_cast<int>(i);
  std::string known;
  for (const auto& n : names) known += (known.empty() ? "" : ", ") + n;
  throw std::invalid_argument("unknown parameter '" + name + "'; known: " + known);
}

}  // namespace twill
