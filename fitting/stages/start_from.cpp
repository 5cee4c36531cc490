// Stage `start-from`: the parameters of a params.yaml as the fit's current point, in place of
// the small-strain slopes' start (paper §5.3). Later stages fit from there; with no fitting
// stage after it, the protocol evaluates given parameters against a dataset, e.g.
//
//   protocol: [{name: start-from, params: out/fit-cc/params.yaml}, {name: final-curves},
//              {name: bend, fit_thickness: false}, {name: validation}]
//
// gives the fit, drape and validation errors of Catmull–Clark-fitted parameters on whatever
// discretisation the config names (papers/transfer/). The file is read and checked when the
// protocol is checked, before any stage runs; a relative path is read from the working folder
// (as every path of the command line).
#include <algorithm>

#include "core/input_error.hpp"
#include "core/option_binding.hpp"
#include "core/params_io.hpp"
#include "fitting/fit_context.hpp"
#include "fitting/fit_stage.hpp"
#include "fitting/stages/stage_kinds.hpp"

namespace twill {
namespace {

struct StartFromOptions {
  std::string params;
  bool validate(std::string* error) const;
};

OptionBindings<StartFromOptions> start_from_bindings() {
  using S = StartFromOptions;
  return {path_option<S>("params", &S::params,
                         "params.yaml the fit continues from (relative: from the working folder); read before any stage runs")};
}

bool StartFromOptions::validate(std::string* error) const {
  if (params.empty()) {
    *error = "params: the params.yaml to start from is required";
    return false;
  }
  return check_options(start_from_bindings(), *this, error);
}

// The fit's effects are the config's, in its order (the effect-fit stages and the fit's end
// look them up so): each with the file's values when the file holds it, else as configured
// (neutral by default); an effect of the file the config does not name is left out, and said.
std::vector<ComponentChoice> effects_in_config_order(FitContext& context, const std::vector<ComponentChoice>& in_file) {
  std::vector<ComponentChoice> out;
  for (const ComponentChoice& configured : context.config().effects) {
    const auto found = std::find_if(in_file.begin(), in_file.end(),
                                    [&](const ComponentChoice& c) { return c.name == configured.name; });
    out.push_back(found != in_file.end() ? *found : configured);
  }
  for (const ComponentChoice& c : in_file)
    if (std::none_of(out.begin(), out.end(), [&](const ComponentChoice& o) { return o.name == c.name; }))
      context.note("start-from: effect " + c.name + " of the file left out (the config's effects do not name it)");
  return out;
}

class StartFrom final : public FitStage {
 public:
  explicit StartFrom(StartFromOptions options) : options_(std::move(options)) {}
  std::string title() const override { return "start from " + options_.params; }
  bool sets_all_parameters() const override { return true; }

  void check(const ProtocolCheck& check) const override {
    try {
      read_params_file(options_.params, check.registry);
    } catch (const InputError& e) {
      throw InputError(check.locate(check.key + ".params"), e.what());
    } catch (const std::exception& e) {
      throw InputError(check.locate(check.key + ".params"), options_.params + ": " + e.what());
    }
  }

  void run(FitContext& context, FitReport& out) override {
    (void)out;
    MaterialParameters file = read_params_file(options_.params, &context.registry());
    file.effects = effects_in_config_order(context, file.effects);
    context.params = std::move(file);
    context.note("parameters from " + options_.params + " (start-from stage)");
  }

 private:
  StartFromOptions options_;
};

}  // namespace

void register_start_from_stage(FitStageFactories& stages) {
  stages.add_bound<StartFrom>("start-from", "the parameters of a params.yaml as the current point (instead of the slopes' start)",
                              start_from_bindings());
}

}  // namespace twill
