#include "fitting/strip_curves.hpp"

#include <algorithm>

#include <tbb/parallel_for.h>

#include "effects/effect_experiment.hpp"

namespace twill {

TensileCurve StripCurves::run_anchored(TensileExperiment& experiment, const TensileTest& test,
                                       const std::vector<double>& extensions) const {
  const auto anchor = anchors_.find(&test);
  if (anchor != anchors_.end()) {
    const AngleAnchor& a = anchor->second;
    const double offset = experiment.setup().angle_deg - a.angle_deg;
    std::vector<Eigen::VectorXd> guesses;
    for (double e : extensions) {
      const auto at = std::find(a.extensions.begin(), a.extensions.end(), e);
      if (at == a.extensions.end()) break;
      const size_t j = static_cast<size_t>(at - a.extensions.begin());
      if (a.q[j].size() != experiment.discretization().num_dofs()) break;  // another level's anchor
      guesses.push_back(a.q[j] + offset * a.dq_dangle[j]);
    }
    if (guesses.size() == extensions.size()) {
      TensileCurve curve = experiment.run_from(extensions, guesses);
      if (curve.completed) return curve;
    }
  }
  return experiment.run(extensions);
}

std::optional<StripCurves::StrainField> StripCurves::anchor_strain_field(const TensileTest& test) const {
  const auto a = anchors_.find(&test);
  if (a == anchors_.end() || a->second.strain_samples.empty()) return std::nullopt;
  return StrainField{a->second.extensions.back(), a->second.strain_samples};
}

const StripCurves::KeptCurve* StripCurves::kept(const TensileTest* test, double angle_deg, int level,
                                                const MaterialParameters& params,
                                                const std::vector<double>& extensions) const {
  for (const KeptCurve& k : kept_) {
    if (k.test != test || k.angle_deg != angle_deg || k.level != level || !(k.params == params)) continue;
    const bool covers = std::all_of(extensions.begin(), extensions.end(), [&](double e) {
      return std::any_of(k.points.begin(), k.points.end(), [&](const TensilePoint& p) { return p.extension_mm == e; });
    });
    if (covers) return &k;
  }
  return nullptr;
}

namespace {

// The requests of one test at one angle: one strip simulated for all of them, over the union
// of their extensions (sorted, each once).
struct Group {
  const TensileTest* test;
  double angle_deg;
  std::vector<double> extensions;
  TensileCurve curve;
  std::vector<Eigen::Vector3d> strain_samples;
};

std::vector<Group> group_requests(const std::vector<StripCurves::Request>& requests, std::vector<size_t>* group_of) {
  std::vector<Group> groups;
  group_of->resize(requests.size());
  for (size_t r = 0; r < requests.size(); ++r) {
    const StripCurves::Request& q = requests[r];
    auto g = std::find_if(groups.begin(), groups.end(),
                          [&](const Group& x) { return x.test == q.run->test && x.angle_deg == q.angle_deg; });
    if (g == groups.end()) g = groups.insert(groups.end(), Group{q.run->test, q.angle_deg, {}, {}, {}});
    g->extensions.insert(g->extensions.end(), q.run->extension_mm.begin(), q.run->extension_mm.end());
    (*group_of)[r] = static_cast<size_t>(g - groups.begin());
  }
  for (Group& g : groups) {
    std::sort(g.extensions.begin(), g.extensions.end());
    g.extensions.erase(std::unique(g.extensions.begin(), g.extensions.end()), g.extensions.end());
  }
  return groups;
}

// A run's forces (and dF/dθ) at its own extensions from its group's points; nothing when the
// curve stopped before the last of them.
std::optional<StripCurves::Simulated> run_forces(const std::vector<TensilePoint>& points,
                                                 const std::vector<double>& wanted) {
  StripCurves::Simulated run{Eigen::VectorXd(static_cast<Eigen::Index>(wanted.size())),
                             Eigen::VectorXd(static_cast<Eigen::Index>(wanted.size()))};
  size_t j = 0;
  for (size_t i = 0; i < wanted.size(); ++i) {
    while (j < points.size() && points[j].extension_mm != wanted[i]) ++j;
    if (j == points.size()) return std::nullopt;
    run.force_N[static_cast<Eigen::Index>(i)] = points[j].force_N;
    run.dforce_dangle[static_cast<Eigen::Index>(i)] = points[j].dforce_dangle;
  }
  if (wanted.empty()) return std::nullopt;
  return run;
}

}  // namespace

std::vector<std::optional<StripCurves::Simulated>> StripCurves::simulate(const FitContext& context,
                                                                         const std::vector<Request>& requests,
                                                                         int level, bool angle_derivative) {
  std::vector<size_t> group_of;
  std::vector<Group> groups = group_requests(requests, &group_of);
  // The model's effects (effects/effect_experiment.hpp): the law hooks before the strips
  // simulate, the observable hooks added to each request's forces below.
  const auto effects = instantiate_effects(context.params, context.registry());
  const MaterialParameters adjusted = apply_law_hooks(effects, context.params);
  std::vector<bool> answered(groups.size(), false);
  if (!angle_derivative)  // an anchor needs the states, which kept curves drop
    for (size_t i = 0; i < groups.size(); ++i)
      if (const KeptCurve* k = kept(groups[i].test, groups[i].angle_deg, level, adjusted, groups[i].extensions)) {
        groups[i].curve.points = k->points;
        groups[i].curve.completed = answered[i] = true;
      }
  tbb::parallel_for(size_t{0}, groups.size(), [&](size_t i) {
    if (answered[i]) return;
    Group& g = groups[i];
    TensileSetup setup = context.setup_for(*g.test, level);
    setup.angle_deg = g.angle_deg;
    TensileExperiment experiment(setup, context.discretization(), adjusted, context.solver());
    experiment.set_angle_sensitivity(angle_derivative);
    experiment.set_keep_states(angle_derivative);
    g.curve = run_anchored(experiment, *g.test, g.extensions);
    if (angle_derivative && g.curve.completed && !g.curve.points.empty())
      g.strain_samples = experiment.material_strain_samples(g.curve.points.back().q);
  });
  if (angle_derivative)
    for (Group& g : groups) {
      if (!g.curve.completed) continue;
      AngleAnchor& a = anchors_[g.test];
      a = AngleAnchor{g.angle_deg, g.extensions, {}, {}, std::move(g.strain_samples)};
      for (TensilePoint& p : g.curve.points) {
        a.q.push_back(std::move(p.q));
        a.dq_dangle.push_back(std::move(p.dq_dangle));
      }
    }
  // Kept after the anchors took the states out (the strips compute no parameter derivatives).
  for (size_t i = 0; i < groups.size(); ++i)
    if (!answered[i] && groups[i].curve.completed)
      kept_.push_back({groups[i].test, groups[i].angle_deg, level, adjusted, groups[i].curve.points});
  std::vector<std::optional<Simulated>> out(requests.size());
  for (size_t r = 0; r < requests.size(); ++r) {
    out[r] = run_forces(groups[group_of[r]].curve.points, requests[r].run->extension_mm);
    if (out[r] && !effects.empty()) {
      const ObservableChange change = observable_additions(
          effects, FitContext::run_conditions(*requests[r].run, requests[r].angle_deg), adjusted, out[r]->force_N.size());
      out[r]->force_N += change.added;
      out[r]->dforce_dangle += change.d_angle;
    }
  }
  return out;
}

}  // namespace twill
