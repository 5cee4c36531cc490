#include "discretizations/triangle_shell/register_triangle_shell.hpp"

#include "core/discretization_registry.hpp"
#include "discretizations/triangle_shell/triangle_shell.hpp"

namespace twill {

void register_triangle_shell(Registry& registry) {
  registry.category<DiscretizationFactories>(registry_category::kDiscretization)
      .add("triangle-shell", "linear membrane triangles + orthotropic discrete-shell hinge bending (OpenMesh)",
           triangle_shell_option_schema(),
           [](const Options& o, const StripSpec& strip,
              const MaterialParameters& parameters) -> std::unique_ptr<Discretization> {
             return std::make_unique<TriangleShell>(strip, parameters, triangle_shell_options(o));
           });
}

}  // namespace twill
