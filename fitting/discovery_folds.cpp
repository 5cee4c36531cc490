// The held-out folds of `twill discover` (docs/discovery.md §1, Held out): specimens by the
// parity of their index, cantilevers by the parity of their overhang, and crosshead speeds;
// and the fit runs' error on a fold's held-out specimens.
#include "fitting/discovery_detail.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "effects/effect.hpp"
#include "fitting/fit_config.hpp"
#include "fitting/fit_context.hpp"
#include "fitting/strip_curves.hpp"

namespace twill {

namespace discover_detail {

// Whether the protocol's effect-fit stage of `effect` fits the bend tests' chord angles.
bool fits_chord_angles(const Options& fit, const std::string& effect) {
  for (const ComponentChoice& stage : fit.get_component_list("protocol"))
    if (stage.name == kEffectFitStage && stage.options.get_string("effect") == effect &&
        stage.options.get_string("observable") == "chord_angle_deg")
      return true;
  return false;
}

}  // namespace discover_detail

using namespace discover_detail;

namespace {

// The items of `all` of index parity `parity`; all of them when there is one (it is in both
// folds, so never held out).
template <class T>
std::vector<T> of_parity(const std::vector<T>& all, size_t parity) {
  if (all.size() < 2) return all;
  std::vector<T> kept;
  for (size_t i = parity; i < all.size(); i += 2) kept.push_back(all[i]);
  return kept;
}

// The dataset with each fit test's runs of index parity `parity`.
Dataset specimen_fold(const Dataset& dataset, size_t parity) {
  Dataset fold = dataset;
  for (TensileTest& test : fold.tensile)
    if (test.role == TestRole::Fit) test.runs = of_parity(test.runs, parity);
  return fold;
}

// The dataset with each bend test's cantilevers (its overhangs) of index parity `parity`; the
// tensile tests whole.
Dataset cantilever_fold(const Dataset& dataset, size_t parity) {
  Dataset fold = dataset;
  for (BendTest& bend : fold.bend) bend.overhang_mm = of_parity(bend.overhang_mm, parity);
  return fold;
}

// The two specimen folds (even and odd run index of every fit test).
std::vector<DiscoverFold> specimen_folds(const Dataset& dataset) {
  return {{"fold 1", specimen_fold(dataset, 0), specimen_fold(dataset, 1)},
          {"fold 2", specimen_fold(dataset, 1), specimen_fold(dataset, 0)}};
}

// The fit tests at `speed` (`keep`) or at every other speed (!keep); other tests as they are.
Dataset speed_fold(const Dataset& dataset, double speed, bool keep) {
  Dataset fold = dataset;
  std::erase_if(fold.tensile, [&](const TensileTest& t) {
    return t.role == TestRole::Fit && (t.rate_mm_min.value_or(0.0) == speed) != keep;
  });
  return fold;
}

// One fold per crosshead speed of the fit tests: fitted on that speed's tests, evaluated on the
// others'; none when the fit tests have fewer than two speeds.
std::vector<DiscoverFold> speed_folds(const Dataset& dataset) {
  std::vector<double> speeds;
  for (const TensileTest& t : dataset.tensile)
    if (t.role == TestRole::Fit && t.rate_mm_min && std::find(speeds.begin(), speeds.end(), *t.rate_mm_min) == speeds.end())
      speeds.push_back(*t.rate_mm_min);
  std::vector<DiscoverFold> folds;
  if (speeds.size() < 2) return folds;
  for (double v : speeds)
    folds.push_back({fmt::format("at {:g} mm/min", v), speed_fold(dataset, v, true), speed_fold(dataset, v, false)});
  return folds;
}

bool has_repeats(const Dataset& dataset) {
  for (const TensileTest& test : dataset.tensile)
    if (test.role == TestRole::Fit && test.runs.size() >= 2) return true;
  return false;
}

bool has_repeated_cantilevers(const Dataset& dataset) {
  return std::any_of(dataset.bend.begin(), dataset.bend.end(), [](const BendTest& b) { return b.overhang_mm.size() >= 2; });
}

}  // namespace

std::vector<DiscoverFold> cantilever_folds(const Dataset& dataset) {
  if (!has_repeated_cantilevers(dataset)) return {};
  return {{"cantilevers 1", cantilever_fold(dataset, 0), cantilever_fold(dataset, 1), true},
          {"cantilevers 2", cantilever_fold(dataset, 1), cantilever_fold(dataset, 0), true}};
}

std::vector<DiscoverFold> discover_folds(const Dataset& dataset, Effect::HeldOut kind, std::string* held, std::string* why) {
  if (kind == Effect::HeldOut::speeds) {
    std::vector<DiscoverFold> folds = speed_folds(dataset);
    if (!folds.empty()) {
      *held = kHeldSpeeds;
      return folds;
    }
  }
  *held = kHeldSpecimens;
  if (!has_repeats(dataset)) {
    *why = "every fit test has one specimen (needs two or more per test)";
    return {};
  }
  return specimen_folds(dataset);
}

double fit_runs_error_at(const Dataset& dataset, const Options& fit, const Registry& registry,
                         const MaterialParameters& params, int level) {
  const FitConfig config = read_fit_config(with_effects(fit, {}, registry));
  FitContext context(dataset, config, registry, {});
  context.params = params;
  select_data(context);
  std::vector<StripCurves::Request> requests;
  for (const RunData& d : context.fit_runs) requests.push_back({&d, FitContext::strip_angle(d)});
  const auto simulated = StripCurves().simulate(context, requests, level);
  std::vector<double> errors;
  for (size_t i = 0; i < simulated.size(); ++i) {
    const RunData& d = context.fit_runs[i];
    if (!simulated[i]) throw std::runtime_error(FitContext::run_label(d) + " could not be simulated");
    const Eigen::VectorXd& p = simulated[i]->force_N;
    const double s = linearised_l1_minimiser(Eigen::VectorXd::Zero(p.size()), p, d.force_N);
    errors.push_back((s * p - d.force_N).cwiseAbs().sum() / d.force_N.cwiseAbs().sum());
  }
  if (errors.empty()) throw std::runtime_error("no fit run to evaluate");
  return mean(errors);
}

}  // namespace twill
