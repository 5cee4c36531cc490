#include "discretizations/catmull_clark_kl/register_catmull_clark_kl.hpp"

#include "core/discretization_registry.hpp"
#include "discretizations/catmull_clark_kl/catmull_clark_kl.hpp"

namespace twill {

void register_catmull_clark_kl(Registry& registry) {
  OptionSchema options;
  options.add_int("gauss_points_per_direction", 4, "Gauss points per face direction (paper §6.3: 4x4)").range(1, 8);
  options.add_int("thickness_points", 3, "Gauss-Legendre points through the thickness").range(2, 8);
  options.add_int("threads", 0, "assembly threads; 0 = TBB's choice").range(0, 256);
  options.add_int("surface_samples_per_face", 4, "limit-surface samples per face edge for OBJ output").range(1, 32);
  options.add_string("fibre_strain", "pointwise",
                     "fibre stretches per Gauss point (paper) or face-mean (B-bar against locking; docs/catmull_clark_kl.md 12)")
      .choices({"pointwise", "face-mean"});
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
             cc.fibre_strain = o.get_string("fibre_strain") == "face-mean" ? FibreStrain::FaceMean
                                                                            : FibreStrain::Pointwise;
             return std::make_unique<CatmullClarkKL>(strip, parameters, cc);
           });
}

}  // namespace twill
