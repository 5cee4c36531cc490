// The flat parameter vector (core/parameters.hpp): layout, names, Σμ = 1 by construction.
#include "core/parameters.hpp"

#include <gtest/gtest.h>

namespace twill {
namespace {

MaterialParameters sample() {
  MaterialParameters p;
  p.eta1 = Curve{{1.3, -0.3}, {2.0, 40.0}};
  p.eta3 = Curve{{0.5, 0.3, 0.2}, {1.0, 12.0, 30.0}};
  p.eta4 = Curve{{1.0}, {5.0}};
  return p;
}

TEST(Parameters, FlatLayoutAndNames) {
  const MaterialParameters p = sample();
  const auto names = p.parameter_names();
  ASSERT_EQ(static_cast<int>(names.size()), p.flat_size());
  // ..., curves η1, η3, η4 of degrees 2, 3, 1, the coupling curve η2 (linear), bending ratios
  EXPECT_EQ(p.flat_size(), 6 + 3 + 5 + 1 + 1 + 2);
  EXPECT_EQ(names[0], "density_kg_m2");
  EXPECT_EQ(names[6], "eta1.mu[1]");
  EXPECT_EQ(names[7], "eta1.alpha[0]");
  EXPECT_EQ(names[9], "eta3.mu[1]");
  EXPECT_EQ(names[14], "eta4.alpha[0]");
  EXPECT_EQ(names[15], "eta2.alpha[0]");
  EXPECT_EQ(names[16], "bending.warp_ratio");
  EXPECT_EQ(names.back(), "bending.weft_ratio");
  const FlatLayout layout(p);
  EXPECT_EQ(layout.eta2, 15);
  EXPECT_EQ(layout.bending, 16);
  EXPECT_EQ(layout.effects, p.flat_size());
  EXPECT_EQ(p.index_of("G12_Pa"), 5);
  EXPECT_THROW(p.index_of("eta2.mu[0]"), std::invalid_argument);  // μ_0 is dependent (Σμ = 1)
}

TEST(Parameters, FlatRoundTripKeepsSumOfMuOne) {
  MaterialParameters p = sample();
  Eigen::VectorXd k = p.to_flat();
  k[p.index_of("eta3.mu[2]")] = 0.45;
  p.set_from_flat(k);
  EXPECT_DOUBLE_EQ(p.eta3.mu[2], 0.45);
  EXPECT_NEAR(p.eta3.mu[0] + p.eta3.mu[1] + p.eta3.mu[2], 1.0, 1e-15);
  EXPECT_EQ(p.to_flat(), k);
  EXPECT_THROW(p.set_from_flat(Eigen::VectorXd::Zero(3)), std::invalid_argument);
  k[p.index_of("bending.weft_ratio")] = 2.5;
  p.set_from_flat(k);
  EXPECT_EQ(p.bending_weft_ratio, 2.5);
  EXPECT_EQ(p.bending_warp_ratio, 1.0);  // the paper's model
}

}  // namespace
}  // namespace twill
