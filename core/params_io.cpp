#include "core/params_io.hpp"

#include "core/registry.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <optional>
#include <stdexcept>

namespace twill {
namespace {

struct Problem {
  std::string key;  // key path relative to the parameter block, e.g. "eta1.mu"
  std::string message;
};

std::string indexed(const std::string& key, std::size_t i) { return key + "[" + std::to_string(i) + "]"; }

std::optional<Problem> curve_problem(const std::string& name, const Curve& c) {
  if (c.mu.empty()) return Problem{name + ".mu", "a curve needs at least one term (degree ≥ 1)"};
  if (c.mu.size() != c.alpha.size())
    return Problem{name + ".alpha", "mu has " + std::to_string(c.mu.size()) + " entries but alpha has " +
                                        std::to_string(c.alpha.size()) + "; both must have one per term"};
  for (std::size_t i = 0; i < c.alpha.size(); ++i)
    if (c.alpha[i] == 0.0) return Problem{indexed(name + ".alpha", i), "alpha must be non-zero"};
  double sum = 0.0, scale = 0.0;
  for (double m : c.mu) {
    sum += m;
    scale += std::abs(m);
  }
  // η'(0) = Σμ must be 1 (paper §3.1); tolerance relative to Σ|μ|, the rounding scale of the sum.
  if (std::abs(sum - 1.0) > 1e-9 * scale)
    return Problem{name + ".mu", "the weights must sum to 1 (η'(0) = 1, paper §3.1); they sum to " +
                                     format_double(sum) + " (tolerance 1e-9 relative to Σ|mu|)"};
  return std::nullopt;
}

std::optional<Problem> find_problem(const MaterialParameters& p) {
  const std::pair<const char*, double> positive[] = {{"density_kg_m2", p.density_kg_m2},
                                                     {"thickness_m", p.thickness_m},
                                                     {"a11_Pa", p.a11_Pa},
                                                     {"a22_Pa", p.a22_Pa},
                                                     {"G12_Pa", p.G12_Pa},
                                                     {kBendingWarpRatioName, p.bending_warp_ratio},
                                                     {kBendingWeftRatioName, p.bending_weft_ratio}};
  for (const auto& [key, value] : positive)
    if (!(value > 0.0)) return Problem{key, "must be positive, got " + format_double(value)};
  if (!(p.a12_Pa >= 0.0)) return Problem{"a12_Pa", "must be zero or positive, got " + format_double(p.a12_Pa)};
  if (!(p.a12_Pa * p.a12_Pa < p.a11_Pa * p.a22_Pa))
    return Problem{"a12_Pa", "a12² must be below a11·a22 (positive-definite small-strain stiffness); "
                             "a12 = " + format_double(p.a12_Pa) + ", sqrt(a11·a22) = " +
                                 format_double(std::sqrt(p.a11_Pa * p.a22_Pa))};
  const std::pair<const char*, const Curve*> curves[] = {
      {"eta1", &p.eta1}, {"eta3", &p.eta3}, {"eta4", &p.eta4}, {"eta2", &p.eta2}};
  for (const auto& [name, curve] : curves)
    if (auto problem = curve_problem(name, *curve)) return problem;

  const auto& c = p.cutoffs;
  const char* rest_state = " (the validity box must contain the rest state, model.md §4)";
  if (c.E11_min && *c.E11_min > 0.0)
    return Problem{"cutoffs.E11_min", "must be ≤ 0, got " + format_double(*c.E11_min) + rest_state};
  if (c.E22_min && *c.E22_min > 0.0)
    return Problem{"cutoffs.E22_min", "must be ≤ 0, got " + format_double(*c.E22_min) + rest_state};
  if (c.E11_max && !(*c.E11_max > 0.0))
    return Problem{"cutoffs.E11_max", "must be > 0, got " + format_double(*c.E11_max) + rest_state};
  if (c.E22_max && !(*c.E22_max > 0.0))
    return Problem{"cutoffs.E22_max", "must be > 0, got " + format_double(*c.E22_max) + rest_state};
  if (c.E12_max && !(*c.E12_max > 0.0))
    return Problem{"cutoffs.E12_max", "must be > 0, got " + format_double(*c.E12_max) + rest_state};
  return std::nullopt;
}

// Reads the blocks while remembering the line of every key path, so that a constraint found
// afterwards (find_problem) still points at the right line.
class ParamsReader {
 public:
  ParamsReader(const YamlValue& root, const Registry* registry) : root_(root), registry_(registry) {}

  MaterialParameters read() {
    YamlMap map(root_);
    map.expect({"model", "density_kg_m2", "thickness_m", "a11_Pa", "a12_Pa", "a22_Pa", "G12_Pa", "eta1", "eta3", "eta4",
                "eta2", "cutoffs", "effects"});
    MaterialParameters p;
    const YamlValue model = take(map, "model");
    if (model.as_string() != kClyde2017ModelName)
      throw model.error("unknown model '" + model.as_string() + "'; known models: " + kClyde2017ModelName);
    p.density_kg_m2 = take(map, "density_kg_m2").as_double();
    p.thickness_m = take(map, "thickness_m").as_double();
    p.a11_Pa = take(map, "a11_Pa").as_double();
    p.a12_Pa = take(map, "a12_Pa").as_double();
    p.a22_Pa = take(map, "a22_Pa").as_double();
    p.G12_Pa = take(map, "G12_Pa").as_double();
    p.eta1 = read_curve(take(map, "eta1"));
    p.eta3 = read_curve(take(map, "eta3"));
    p.eta4 = read_curve(take(map, "eta4"));
    if (map.find("eta2")) p.eta2 = read_curve(take(map, "eta2"));  // optional: the paper's η2(x) = x
    p.cutoffs = read_cutoffs(take(map, "cutoffs"));
    if (const auto effects = map.find("effects")) p.effects = read_effects(*effects);
    map.finish();
    if (auto problem = find_problem(p)) {
      const std::string path = join_key_path(root_.path(), problem->key);
      throw InputError({root_.file(), line_of(problem->key), path}, problem->message);
    }
    return p;
  }

 private:
  YamlValue take(YamlMap& map, const std::string& key) {
    YamlValue v = map.get(key);
    record(v);
    return v;
  }

  void record(const YamlValue& v) {
    // Store the path relative to the block, as find_problem names keys.
    std::string rel = v.path();
    if (!root_.path().empty()) rel = rel.substr(root_.path().size() + 1);
    lines_[rel] = v.line();
  }

  int line_of(const std::string& key) const {
    auto it = lines_.find(key);
    if (it != lines_.end()) return it->second;
    // e.g. "eta1.alpha[1]" -> "eta1.alpha" -> "eta1"
    const auto cut = key.find_last_of(".[");
    return cut == std::string::npos ? root_.line() : line_of(key.substr(0, cut));
  }

  std::vector<double> read_list(const YamlValue& v) {
    std::vector<double> out;
    for (const auto& item : v.items()) {
      record(item);
      out.push_back(item.as_double());
    }
    return out;
  }

  Curve read_curve(const YamlValue& v) {
    YamlMap map(v);
    map.expect({"mu", "alpha"});
    Curve c;
    c.mu = read_list(take(map, "mu"));
    c.alpha = read_list(take(map, "alpha"));
    map.finish();
    return c;
  }

  Cutoffs read_cutoffs(const YamlValue& v) {
    YamlMap map(v);
    const auto& keys = map.keys();
    if (std::find(keys.begin(), keys.end(), "E12_min") != keys.end()) {
      const YamlValue bad(v.node()["E12_min"], v.file(), map.child_path("E12_min"));
      throw bad.error("unknown key: E12_min is not a key, the shear box is symmetric (E12_min = -E12_max)");
    }
    map.expect({"E11_min", "E11_max", "E22_min", "E22_max", "E12_max"});
    Cutoffs c;
    if (auto min11 = map.find("E11_min")) {
      record(*min11);
      c.E11_min = min11->as_optional_double();
    }
    if (auto min22 = map.find("E22_min")) {
      record(*min22);
      c.E22_min = min22->as_optional_double();
    }
    c.E11_max = take(map, "E11_max").as_optional_double();
    c.E22_max = take(map, "E22_max").as_optional_double();
    c.E12_max = take(map, "E12_max").as_optional_double();
    map.finish();
    return c;
  }

  // `effects:`: each key a registered effect, its value that effect's parameters resolved
  // against its schema (config.hpp: unknown key, type and bounds are InputErrors).
  std::vector<ComponentChoice> read_effects(const YamlValue& v) {
    if (v.is_null()) return {};
    YamlMap map(v);
    std::vector<ComponentChoice> effects;
    for (const std::string& name : map.keys()) {
      const YamlValue value = map.get(name);
      const RegistryCategory* category = registry_ ? registry_->find_category(registry_category::kEffect) : nullptr;
      const RegistryEntry* entry = category ? category->find(name) : nullptr;
      if (!entry)
        throw value.error("unknown effect '" + name + "' (known: " + (category ? category->known_names() : "none registered") + ")");
      effects.push_back({registry_category::kEffect, name, resolve_options(entry->options, value, registry_)});
    }
    map.finish();
    return effects;
  }

  YamlValue root_;
  const Registry* registry_;
  std::map<std::string, int> lines_;
};

// An effect parameter's value as flow-style YAML (effects' schemas hold scalars).
std::string scalar_text(const OptionValue& value) {
  if (const auto* d = std::get_if<double>(&value)) return format_double(*d);
  if (const auto* i = std::get_if<std::int64_t>(&value)) return std::to_string(*i);
  if (const auto* b = std::get_if<bool>(&value)) return *b ? "true" : "false";
  if (const auto* t = std::get_if<std::string>(&value)) return *t;
  throw std::logic_error("params.yaml: an effect parameter that is not a scalar");
}

std::string effects_text(const std::vector<ComponentChoice>& effects) {
  if (effects.empty()) return "";
  std::string out = "effects:\n";
  for (const ComponentChoice& effect : effects) {
    out += "  " + effect.name + ": {";
    for (std::size_t i = 0; i < effect.options.entries().size(); ++i) {
      const OptionEntry& e = effect.options.entries()[i];
      out += (i ? ", " : "") + e.key + ": " + scalar_text(e.value);
    }
    out += "}\n";
  }
  return out;
}

std::string list_text(const std::vector<double>& values) {
  std::string out = "[";
  for (std::size_t i = 0; i < values.size(); ++i) out += (i ? ", " : "") + format_double(values[i]);
  return out + "]";
}

std::string optional_text(const std::optional<double>& value) { return value ? format_double(*value) : "null"; }

}  // namespace

MaterialParameters read_params(const YamlValue& value, const Registry* registry) {
  return ParamsReader(value, registry).read();
}

MaterialParameters read_params_file(const std::string& path, const Registry* registry) {
  return read_params(load_yaml_file(path), registry);
}

void validate_parameters(const MaterialParameters& parameters, const std::string& source) {
  if (auto problem = find_problem(parameters)) throw InputError({source, 0, problem->key}, problem->message);
}

std::string params_to_yaml(const MaterialParameters& p) {
  std::string out;
  out += "# twill material parameters (Clyde, Teran & Tamstorf 2017); SI units, docs/dataset-format.md\n";
  out += std::string("model: ") + kClyde2017ModelName + "\n";
  out += "density_kg_m2: " + format_double(p.density_kg_m2) + "\n";
  out += "thickness_m: " + format_double(p.thickness_m) + "\n";
  out += "a11_Pa: " + format_double(p.a11_Pa) + "\n";
  out += "a12_Pa: " + format_double(p.a12_Pa) + "\n";
  out += "a22_Pa: " + format_double(p.a22_Pa) + "\n";
  out += "G12_Pa: " + format_double(p.G12_Pa) + "\n";
  const std::pair<const char*, const Curve*> curves[] = {{"eta1", &p.eta1}, {"eta3", &p.eta3}, {"eta4", &p.eta4}};
  for (const auto& [name, c] : curves)
    out += std::string(name) + ": {mu: " + list_text(c->mu) + ", alpha: " + list_text(c->alpha) + "}\n";
  if (p.eta2 != Curve::linear())  // the paper's η2(x) = x is the key's absence
    out += "eta2: {mu: " + list_text(p.eta2.mu) + ", alpha: " + list_text(p.eta2.alpha) + "}\n";
  const auto& c = p.cutoffs;
  out += "cutoffs: {E11_min: " + optional_text(c.E11_min) + ", E11_max: " + optional_text(c.E11_max) +
         ", E22_min: " + optional_text(c.E22_min) + ", E22_max: " + optional_text(c.E22_max) +
         ", E12_max: " + optional_text(c.E12_max) + "}\n";
  out += effects_text(p.effects);
  return out;
}

void write_params_file(const MaterialParameters& parameters, const std::string& path) {
  std::ofstream out(path, std::ios::binary);
  if (!out) throw std::runtime_error("cannot write parameter file " + path);
  out << params_to_yaml(parameters);
  if (!out.flush()) throw std::runtime_error("failed writing parameter file " + path);
}

}  // namespace twill
