#pragma once
// Experiment: a registered simulated test (core/registry.hpp, category "experiment").
//
// An experiment is built from one test of a dataset (the fit) or from `twill simulate`'s
// arguments: an ExperimentInput says the strip's angle and size, the schedule (what the lab
// varied: clamp extensions, overhangs), the measured observables when there are any, the
// resolution, the discretisation factory (the experiment asks it for its mesh) and the
// starting material. The experiment runs the equilibrium solver along its schedule and
// returns one predicted observable per schedule entry, with parameter derivatives by Eq. 6
// (core/sensitivity.hpp) when asked: it is the fit objective's Predictor (core/fit_objective).
//
// Set-up sensitivities: an experiment may also report the derivative of its observables in a
// quantity of its set-up (today the strip angle, "angle_deg"): effects whose hook changes the
// set-up (effects/effect.hpp, e.g. misalignment) chain their parameter derivatives through it.
//
// Registered experiments (experiments/register_experiments.cpp; `twill list experiment`):
//   tensile     the ASTM D5035-like strip (tensile_strip.hpp): clamp force [N] per extension;
//   bend        the ASTM D1388 cantilever (cantilever.hpp): chord angle [deg] per overhang;
//   validation  a tensile strip at an off-axis angle, reported with dF/dθ (paper §7);
//   tensile-lateral  the strip's lateral strain at mid-gauge per extension (what a video
//               extensometer or DIC measures; identifies a12, effects/poisson).
//
// Factory: (resolved options, input) -> the experiment. Options are the experiment's own
// choices (e.g. the tensile strip's `planar`), validated against its schema by the registry.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "core/equilibrium_solver.hpp"
#include "core/fit_objective.hpp"
#include "core/registry.hpp"
#include "experiments/strip_factory.hpp"

namespace twill {

/// Quantities of an experiment's set-up whose observable derivatives an experiment can report.
namespace setup_quantity {
inline constexpr const char* kAngle = "angle_deg";  ///< strip axis vs weft [deg]
}  // namespace setup_quantity

/// What an experiment is built from.
struct ExperimentInput {
  std::string label;           ///< e.g. "warp-2 (90°)", for messages and reports
  double angle_deg = 90;       ///< strip axis vs weft [deg] (model.md §7)
  double width_mm = 0;         ///< strip width; 0: the experiment's standard width
  double length_mm = 0;        ///< tensile gauge length; 0: the standard one (unused by bend)
  std::vector<double> schedule;  ///< tensile: extensions [mm]; bend: overhangs [mm]
  /// The run's clock, for effects whose predictions depend on time (effects/effect.hpp):
  /// crosshead speed [mm/min] (0: not known) and the time of each schedule entry [s] (empty:
  /// not known). The elastic experiments ignore both.
  double rate_mm_min = 0;
  std::vector<double> time_s;
  /// Measured observables at the schedule (same size, none zero), or empty (simulation only).
  Eigen::VectorXd measured;
  int cells_across = 0;        ///< resolution; 0: the experiment's default
  int cells_along = 0;
  DiscretizationFactory discretization;
  MaterialParameters start;
  EquilibriumOptions solver;
};

/// One run of an experiment along its schedule, with what the solver did.
struct ExperimentRun {
  std::vector<double> schedule;  ///< the entries that converged, in order
  Eigen::VectorXd values;        ///< observables at them
  /// Further per-entry outputs by name, e.g. {"lateral_strain", ...} (same length).
  std::vector<std::pair<std::string, std::vector<double>>> extras;
  bool completed = false;        ///< every schedule entry converged
  std::string message;           ///< why it stopped early
  int newton_iterations = 0;
  double wall_time_s = 0;
};

class Experiment : public Predictor {
 public:
  /// The observable with its unit, e.g. "force_N", and the scheduled quantity, e.g. "extension_mm".
  virtual std::string observable() const = 0;
  virtual std::string schedule_quantity() const = 0;
  virtual const std::vector<double>& schedule() const = 0;
  /// Runs the schedule at `k` without derivatives; never throws for a failed solve (the run
  /// then ends early with completed = false).
  virtual ExperimentRun simulate(const MaterialParameters& k) = 0;
  /// d(observables)/d(set-up quantity) at k (one column per quantity), for the quantities in
  /// setup_sensitivities(). False with a message when a solve failed.
  virtual std::vector<std::string> setup_sensitivities() const { return {}; }
  virtual bool predict_setup_derivatives(const MaterialParameters& k, const std::vector<std::string>& quantities,
                                         Eigen::VectorXd* values, Eigen::MatrixXd* jacobian, std::string* message);
  /// The surface of the last equilibrium (OBJ export); false when there is none yet.
  virtual bool last_surface(Eigen::MatrixXd* V, Eigen::MatrixXi* F) const = 0;
};

using ExperimentFactories = FactoryCategory<Experiment, const ExperimentInput&>;

}  // namespace twill
