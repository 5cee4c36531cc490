#pragma once
// A fit stage (issue #14 item 3): one step of the protocol, registered in category `stage`
// with typed options (core/option_binding.hpp) and created from a `protocol` entry of the fit
// config (fitting/fit_config.hpp). The protocol runs its stages in order on one FitContext
// (the fit's state: runs, parameters, the fitted curve stages) and fills the report from what
// each stage returns (run()'s `out`). The kinds are in fitting/stages/, one file each, and
// registered by register_fit_stages(); docs/fitting.md describes them, docs/extending.md
// says how to add one.
#include <memory>
#include <string>
#include <vector>

#include "core/dataset.hpp"
#include "core/input_error.hpp"
#include "core/registry.hpp"
#include "fitting/fit_input_checks.hpp"

namespace twill {

class FitContext;
struct FitReport;
struct CurveStage;

/// What the up-front checks of a stage see: the dataset, and the stages before it.
struct ProtocolCheck {
  const Dataset* dataset = nullptr;
  const Registry* registry = nullptr;     ///< every registered part (a file read here names effects)
  std::string key;                    ///< this stage's key path, e.g. "protocol[3]"
  std::vector<std::string> curve_labels;  ///< labels of the tensile-curve stages before it
  int levels = 1;                     ///< the config's resolution levels
  std::vector<std::string> registered_effects;  ///< the registry's effect names
  std::vector<std::string> configured_effects;  ///< the config's `effects`, in order
  ConfigKeyLocator locate;
};

class FitStage {
 public:
  virtual ~FitStage() = default;
  /// The report's name of this stage's step, e.g. "warp (degree, coarsest level)" (timings).
  virtual std::string title() const = 0;
  /// A tensile-curve stage's identity (others: null): later stages refer to it by its label,
  /// and the protocol lists every one before the first stage runs (FitContext::declared_curves).
  virtual const CurveStage* curve_stage() const { return nullptr; }
  /// True for a stage that sets every parameter itself (start-from): a protocol with one
  /// needs no eta1 curve stage to start from.
  virtual bool sets_all_parameters() const { return false; }
  /// Before any work: throws InputError (at check.locate(check.key + ".option")) for a stage
  /// this dataset or protocol cannot run, e.g. a cutoff of a stage that is not before it.
  virtual void check(const ProtocolCheck& check) const { (void)check; }
  /// Runs the stage; what it reports goes into `out` (an empty report the protocol merges).
  virtual void run(FitContext& context, FitReport& out) = 0;
};

using FitStageFactories = FactoryCategory<FitStage>;

/// Registers every stage kind of fitting/stages/ (category `stage`).
void register_fit_stages(Registry& registry);

}  // namespace twill
