#include "discretizations/catmull_clark_kl/register_catmull_clark_kl.hpp"

#include <string>
#include <vector>

#include "core/discretization_registry.hpp"
#include "discretizations/catmull_clark_kl/catmull_clark_kl.hpp"

namespace twill {

void register_catmull_clark_kl(Registry& registry) {
  OptionSchema options;
  options.add_int("gauss_points_per_direction", 4, "Gauss points per face direction (paper §6.3: 4x4)").range(1, 8);
  options.add_int("thickness_points", 3, "Gauss-Legendre points through the thickness").range(2, 8);
  options.add_int("threads", 0, "assembly threads; 0 = TBB's choice").range(0, 256);
  options.add_int("surface_samples_per_face", 4, "limit-surface samples per face edge for OBJ output").range(1, 32);
  std::vector<std::string> fibre_strains;
  for (const auto& [value, name] : fibre_strain_names()) fibre_strains.emplace_back(name);
  options.add_string("fibre_strain", fibre_strain_name(CatmullClarkKLOptions{}.fibre_strain),
                     "fibre stretches per Gauss point (paper) or L2-projected per face onto "
                     "constants / linears / bilinears (B-bar against locking; docs/catmull_clark_kl.md 12)")
      .choices(fibre_strains);
  registry.category<DiscretizationFactories>(registry_category::kDiscretization)
      .add("catmull-clark-kl", "Kirchhoff-Love thin shell on Catmull-Clark limit surfaces (OpenSubdiv)",
           std::move(options),
           [](const Options& o, const StripSpec& strip,
              const MaterialParameters& parameters) -> std::unique_ptr<Discretization> {
             CatmullClarkKLOptions cc;
             cc.gauss_points_per_direction = static_cast<int>(o.get_int("gauss_points_per_direction"));
             cc.thickness_points = static_cast<int>(o.get_int("thickness_points"));
             cc.threads = static_cast<int>(o.get_int("threads"));
             cc.surface_samples_per_face = static_cast<int>(o.get_int("surface_samples_per_face"));
             cc.fibre_strain = fibre_strain_from_name(o.get_string("fibre_strain"));
             return std::make_unique<CatmullClarkKL>(strip, parameters, cc);
           });
}

}  // namespace twill
