#include "discretizations/triangle_shell/register_triangle_shell.hpp"

#include "core/discretization_registry.hpp"
#include "discretizations/triangle_shell/triangle_shell.hpp"

namespace twill {

void register_triangle_shell(Registry& registry) {
  OptionSchema options;
  options.add_string("pattern", "alternating", "how each quad cell is split into triangles")
      .choices({"right", "left", "alternating", "cross", "irregular"});
  options.add_double("perturbation", 0.2, "irregular pattern: vertex offset as a fraction of the cell").range(0.0, 0.2499);
  options.add_int("seed", 1, "irregular pattern: random seed").range(0, 1LL << 62);
  options.add_int("threads", 0, "assembly threads; 0 = TBB's choice").range(0, 256);
  registry.category<DiscretizationFactories>(registry_category::kDiscretization)
      .add("triangle-shell", "linear membrane triangles + orthotropic discrete-shell hinge bending (OpenMesh)",
           std::move(options),
           [](const Options& o, const StripSpec& strip,
              const MaterialParameters& parameters) -> std::unique_ptr<Discretization> {
             TriangleShellOptions t;
             t.pattern = triangle_pattern_from_string(o.get_string("pattern"));
             t.perturbation = o.get_double("perturbation");
             t.seed = static_cast<std::uint64_t>(o.get_int("seed"));
             t.threads = static_cast<int>(o.get_int("threads"));
             return std::make_unique<TriangleShell>(strip, parameters, t);
           });
}

}  // namespace twill
