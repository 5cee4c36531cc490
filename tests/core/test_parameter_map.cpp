// ParameterMap::jacobian (core/fit_objective.hpp) against central differences of
// ParameterMap::parameters: the free entries' scaling, the a12 tie a12 = ½ min(a11, a22)
// (paper §5.2) and the bend stage's thickness rescaling a ← a0·τ0/τ (§5.2 step 7).
#include <gtest/gtest.h>

#include <algorithm>
#include <ostream>
#include <string>
#include <vector>

#include "core/fit_objective.hpp"
#include "tests/support/finite_difference.hpp"
#include "tests/support/test_materials.hpp"

namespace twill {
namespace {

MaterialParameters start() {
  MaterialParameters p = testing::canvas_degree2();
  p.a12_Pa = MaterialParameters::tied_a12(p.a11_Pa, p.a22_Pa);
  return p;
}

struct MapCase {
  const char* label;
  std::vector<std::string> free;
  ParameterMap::Options options;
  /// The map is nonlinear in x (thickness rescaling): central differences must show their
  /// truncation error; linear maps are differenced exactly up to round-off.
  bool nonlinear;
};

void PrintTo(const MapCase& c, std::ostream* os) { *os << c.label; }

class ParameterMapJacobian : public ::testing::TestWithParam<MapCase> {};

TEST_P(ParameterMapJacobian, MatchesCentralDifferencesAtSecondOrder) {
  const MapCase& c = GetParam();
  const ParameterMap map(start(), c.free, c.options);
  // Away from the start (and from a11 = a22, where the tie's min() has a kink).
  Eigen::VectorXd x = map.initial_x();
  for (Eigen::Index i = 0; i < x.size(); ++i) x[i] = x[i] * 1.1 + 0.01 * static_cast<double>(i);
  const std::vector<int>& dependent = map.dependent_indices();
  auto k_of = [&](const Eigen::VectorXd& y) -> Eigen::VectorXd {
    const Eigen::VectorXd flat = map.parameters(y).to_flat();
    Eigen::VectorXd out(static_cast<Eigen::Index>(dependent.size()));
    for (size_t r = 0; r < dependent.size(); ++r) out[static_cast<Eigen::Index>(r)] = flat[dependent[r]];
    return out;
  };
  const Eigen::MatrixXd J = map.jacobian(x);
  ASSERT_EQ(J.rows(), static_cast<Eigen::Index>(dependent.size()));
  ASSERT_EQ(J.cols(), map.dimension());
  bool truncation_seen = false;
  for (int i = 0; i < map.dimension(); ++i) {
    SCOPED_TRACE(map.free_names()[static_cast<size_t>(i)]);
    const Eigen::VectorXd unit = Eigen::VectorXd::Unit(map.dimension(), i);
    const auto check = testing::check_directional_derivative(k_of, x, unit, J.col(i), 1e-2, 4, 1e-6);
    EXPECT_TRUE(check.ok) << check.report;
    truncation_seen |= !check.roundoff_only;
  }
  EXPECT_EQ(truncation_seen, c.nonlinear) << "the case must exercise what it claims";
}

TEST_P(ParameterMapJacobian, TiedAndRescaledEntriesAreDependent) {
  const MapCase& c = GetParam();
  const ParameterMap map(start(), c.free, c.options);
  const std::vector<int>& dependent = map.dependent_indices();
  auto has = [&](int j) { return std::find(dependent.begin(), dependent.end(), j) != dependent.end(); };
  for (int j : map.free_indices()) EXPECT_TRUE(has(j));
  const bool moves_a11_or_a22 = has(FlatLayout::kA11) || has(FlatLayout::kA22);
  if (c.options.tie_a12 && moves_a11_or_a22) {
    EXPECT_TRUE(has(FlatLayout::kA12));
  }
  if (c.options.rescale_with_thickness) {
    for (int j : {FlatLayout::kA11, FlatLayout::kA12, FlatLayout::kA22, FlatLayout::kG12}) EXPECT_TRUE(has(j)) << j;
  }
}

ParameterMap::Options tie(bool tied, bool rescaled) {
  ParameterMap::Options o;
  o.tie_a12 = tied;
  o.rescale_with_thickness = rescaled;
  return o;
}

INSTANTIATE_TEST_SUITE_P(
    Maps, ParameterMapJacobian,
    ::testing::Values(MapCase{"scaled_free_entries", {"a11_Pa", "G12_Pa", "eta1.*"}, tie(false, false), false},
                      MapCase{"a12_tie", {"a11_Pa", "a22_Pa", "eta1.mu[1]"}, tie(true, false), false},
                      MapCase{"thickness_rescale", {"thickness_m", "density_kg_m2"}, tie(false, true), true},
                      MapCase{"tie_and_rescale", {"thickness_m", "eta1.mu[1]"}, tie(true, true), true}),
    [](const auto& map_case) { return std::string(map_case.param.label); });

}  // namespace
}  // namespace twill
