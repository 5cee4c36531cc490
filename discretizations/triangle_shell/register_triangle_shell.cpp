#include "discretizations/triangle_shell/register_triangle_shell.hpp"

#include "core/discretization_registry.hpp"
#include "discretizations/triangle_shell/triangle_shell.hpp"

namespace twill {

void register_triangle_shell(Registry& registry) {
  registry.category<DiscretizationFactories>(registry_category::kDiscretization)
      .add_bound<TriangleShell>("triangle-shell",
                                "linear membrane triangles + orthotropic discrete-shell hinge bending (OpenMesh)",
                                triangle_shell_option_bindings());
}

}  // namespace twill
