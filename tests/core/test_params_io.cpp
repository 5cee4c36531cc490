// Parameter files: the reference files load, write → read is bit-exact, and every malformed
// input gives its own error naming the file, the line and the key.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <ostream>
#include <random>

#include "core/params_io.hpp"

namespace twill {
namespace {

const std::string kShared = TWILL_SHARED_DIR;
const std::string kFixtures = std::string(TWILL_SOURCE_DIR) + "/tests/data/params/";

bool bit_equal(double a, double b) { return std::memcmp(&a, &b, sizeof(double)) == 0; }

void expect_bit_equal(const std::vector<double>& a, const std::vector<double>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) EXPECT_TRUE(bit_equal(a[i], b[i])) << i << ": " << a[i] << " vs " << b[i];
}

void expect_bit_equal(const std::optional<double>& a, const std::optional<double>& b) {
  ASSERT_EQ(a.has_value(), b.has_value());
  if (a) {
    EXPECT_TRUE(bit_equal(*a, *b)) << *a << " vs " << *b;
  }
}

void expect_bit_equal(const MaterialParameters& a, const MaterialParameters& b) {
  EXPECT_TRUE(bit_equal(a.density_kg_m2, b.density_kg_m2));
  EXPECT_TRUE(bit_equal(a.thickness_m, b.thickness_m));
  EXPECT_TRUE(bit_equal(a.a11_Pa, b.a11_Pa));
  EXPECT_TRUE(bit_equal(a.a12_Pa, b.a12_Pa));
  EXPECT_TRUE(bit_equal(a.a22_Pa, b.a22_Pa));
  EXPECT_TRUE(bit_equal(a.G12_Pa, b.G12_Pa));
  for (auto curve : {&MaterialParameters::eta1, &MaterialParameters::eta3, &MaterialParameters::eta4,
                     &MaterialParameters::eta2}) {
    expect_bit_equal((a.*curve).mu, (b.*curve).mu);
    expect_bit_equal((a.*curve).alpha, (b.*curve).alpha);
  }
  expect_bit_equal(a.cutoffs.E11_min, b.cutoffs.E11_min);
  expect_bit_equal(a.cutoffs.E11_max, b.cutoffs.E11_max);
  expect_bit_equal(a.cutoffs.E22_min, b.cutoffs.E22_min);
  expect_bit_equal(a.cutoffs.E22_max, b.cutoffs.E22_max);
  expect_bit_equal(a.cutoffs.E12_max, b.cutoffs.E12_max);
}

TEST(ParamsIo, ReferenceCanvasLoads) {
  const auto p = read_params_file(kShared + "/data/reference/canvas/params.yaml");
  EXPECT_EQ(p.density_kg_m2, 0.294);
  EXPECT_EQ(p.thickness_m, 0.00045000000000000004);
  EXPECT_EQ(p.a11_Pa, 3e7);
  EXPECT_EQ(p.a12_Pa, 1.1e7);
  EXPECT_EQ(p.a22_Pa, 2.2e7);
  EXPECT_EQ(p.G12_Pa, 4e5);
  EXPECT_EQ(p.eta1.mu, (std::vector<double>{0.6, 0.4}));
  EXPECT_EQ(p.eta1.alpha, (std::vector<double>{5.0, 120.0}));
  EXPECT_EQ(p.eta3.degree(), 3);
  EXPECT_EQ(p.eta3.alpha, (std::vector<double>{1.0, 40.0, 160.0}));
  EXPECT_EQ(p.eta4.mu, (std::vector<double>{0.7, 0.3}));
  EXPECT_EQ(p.cutoffs.E11_min, 0.0);
  EXPECT_EQ(p.cutoffs.E22_min, 0.0);
  EXPECT_FALSE(p.cutoffs.E11_max);
  EXPECT_FALSE(p.cutoffs.E22_max);
  EXPECT_FALSE(p.cutoffs.E12_max);
}

TEST(ParamsIo, TruthParamsBlockLoadsAndMatchesReference) {
  const YamlValue root = load_yaml_file(kShared + "/data/examples/truth/canvas.yaml");
  YamlMap map(root);
  const auto p = read_params(map.get("params"));
  expect_bit_equal(p, read_params_file(kShared + "/data/reference/canvas/params.yaml"));
  // The poplin truth block loads too.
  const YamlValue poplin = load_yaml_file(kShared + "/data/examples/truth/poplin.yaml");
  YamlMap poplin_map(poplin);
  EXPECT_GT(read_params(poplin_map.get("params")).a11_Pa, 0.0);
}

TEST(ParamsIo, ContractExampleLoads) {
  const auto p = read_params_file(kFixtures + "valid.yaml");
  EXPECT_EQ(p.eta1.mu, (std::vector<double>{1.3, -0.3}));
  EXPECT_EQ(p.cutoffs.E12_max, 0.35);
  EXPECT_EQ(p.cutoffs.E22_max, 0.18);
}

TEST(ParamsIo, CutoffDefaultsAndNull) {
  const auto p = read_params_file(kFixtures + "cutoff_defaults.yaml");
  EXPECT_EQ(p.cutoffs.E11_min, 0.0);  // absent: default 0 (compression extrapolated from 0)
  EXPECT_FALSE(p.cutoffs.E11_max);    // null: off
  EXPECT_FALSE(p.cutoffs.E22_min);    // explicitly null: compression extrapolation off
  EXPECT_EQ(p.cutoffs.E22_max, 0.18);
  EXPECT_FALSE(p.cutoffs.E12_max);
  // Σμ = 1 + 1e-12 is within the documented 1e-9 relative tolerance.
  EXPECT_EQ(p.eta3.mu[0], 0.500000000001);
}

// Random parameters with full-precision digits, degrees 1–5, cutoffs on and off, the optional
// coupling curve η2 linear (no key written) or not, written and read back: every double must be
// bit-identical.
TEST(ParamsIo, RoundTripIsBitExact) {
  std::mt19937_64 rng(20170728);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const auto dir = std::filesystem::temp_directory_path() / "twill_test_params_io";
  std::filesystem::create_directories(dir);
  for (int trial = 0; trial < 200; ++trial) {
    MaterialParameters p;
    p.density_kg_m2 = 0.05 + unit(rng);
    p.thickness_m = 1e-4 * (1 + unit(rng));
    p.a11_Pa = 1e7 * (1 + 9 * unit(rng));
    p.a22_Pa = 1e7 * (1 + 9 * unit(rng));
    p.a12_Pa = MaterialParameters::tied_a12(p.a11_Pa, p.a22_Pa) * unit(rng);
    p.G12_Pa = 1e5 * (1 + unit(rng));
    const bool linear_coupling = trial % 2 == 0;
    for (Curve* c : {&p.eta1, &p.eta3, &p.eta4, &p.eta2}) {
      if (c == &p.eta2 && linear_coupling) continue;
      const int degree = 1 + static_cast<int>(rng() % 5);
      c->mu.assign(static_cast<std::size_t>(degree), 0.0);
      c->alpha.assign(static_cast<std::size_t>(degree), 0.0);
      double rest = 0;
      for (int i = 1; i < degree; ++i) rest += (c->mu[static_cast<std::size_t>(i)] = unit(rng) - 0.5);
      c->mu[0] = 1.0 - rest;
      for (auto& a : c->alpha) a = (unit(rng) < 0.2 ? -1.0 : 1.0) * (0.5 + 200 * unit(rng));
    }
    auto maybe = [&](double scale) { return unit(rng) < 0.5 ? std::optional<double>() : scale * (0.01 + unit(rng)); };
    p.cutoffs.E11_min = unit(rng) < 0.5 ? std::optional<double>(0.0) : maybe(-1.0);
    p.cutoffs.E22_min = maybe(-1.0);
    p.cutoffs.E11_max = maybe(1.0);
    p.cutoffs.E22_max = maybe(1.0);
    p.cutoffs.E12_max = maybe(1.0);

    const std::string path = (dir / ("p" + std::to_string(trial) + ".yaml")).string();
    write_params_file(p, path);
    const auto q = read_params_file(path);
    expect_bit_equal(p, q);
    EXPECT_EQ(params_to_yaml(p).find("eta2:") == std::string::npos, linear_coupling);
    // And the text is stable: writing the read parameters gives the same file.
    EXPECT_EQ(params_to_yaml(q), params_to_yaml(p));
    if (HasFailure()) {
      ADD_FAILURE() << "trial " << trial << ":\n" << params_to_yaml(p);
      break;
    }
  }
  std::filesystem::remove_all(dir);
}

struct BadParams {
  const char* file;
  int line;
  const char* key;
  const char* message;
};
void PrintTo(const BadParams& c, std::ostream* os) { *os << c.file << ":" << c.line << " " << c.key; }

class ParamsIoErrors : public ::testing::TestWithParam<BadParams> {};

TEST_P(ParamsIoErrors, NamesFileLineAndKey) {
  const BadParams& c = GetParam();
  const std::string path = kFixtures + c.file;
  try {
    read_params_file(path);
    FAIL() << c.file << " was accepted";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_EQ(e.where().file, path) << what;
    EXPECT_EQ(e.where().line, c.line) << what;
    EXPECT_EQ(e.where().key, c.key) << what;
    EXPECT_NE(what.find(path + ":" + std::to_string(c.line)), std::string::npos) << what;
    EXPECT_NE(what.find(c.message), std::string::npos) << "expected '" << c.message << "' in: " << what;
  }
}

INSTANTIATE_TEST_SUITE_P(
    Malformed, ParamsIoErrors,
    ::testing::Values(
        BadParams{"unknown_key.yaml", 8, "a33_Pa", "unknown key"},
        BadParams{"misspelt_key.yaml", 4, "a11_pa", "unknown key (known keys here: G12_Pa, a11_Pa,"},
        BadParams{"missing_key.yaml", 1, "G12_Pa", "missing required key"},
        BadParams{"wrong_type.yaml", 6, "a22_Pa", "expected a number, got 'stiff'"},
        BadParams{"list_for_number.yaml", 3, "thickness_m", "expected a number, got a list"},
        BadParams{"negative_stiffness.yaml", 6, "a22_Pa", "must be positive"},
        BadParams{"zero_thickness.yaml", 3, "thickness_m", "must be positive"},
        BadParams{"negative_density.yaml", 2, "density_kg_m2", "must be positive"},
        BadParams{"coupling_too_large.yaml", 5, "a12_Pa", "positive-definite"},
        BadParams{"mu_alpha_lengths.yaml", 8, "eta1.alpha", "mu has 2 entries but alpha has 1"},
        BadParams{"empty_curve.yaml", 10, "eta4.mu", "at least one term"},
        BadParams{"mu_sum.yaml", 9, "eta3.mu", "tolerance 1e-9 relative"},
        BadParams{"alpha_zero.yaml", 10, "eta4.alpha[1]", "alpha must be non-zero"},
        BadParams{"bad_model.yaml", 1, "model", "unknown model 'clyde2018'"},
        BadParams{"e12_min.yaml", 11, "cutoffs.E12_min", "symmetric"},
        BadParams{"cutoff_wrong_type.yaml", 11, "cutoffs.E11_max", "expected a number or null, got 'off'"},
        BadParams{"cutoff_missing_max.yaml", 11, "cutoffs.E22_max", "missing required key"},
        BadParams{"cutoff_negative_max.yaml", 13, "cutoffs.E22_max", "must be > 0"},
        BadParams{"unknown_curve_key.yaml", 9, "eta3.beta", "unknown key"},
        BadParams{"syntax_error.yaml", 9, "", "YAML syntax error"},
        BadParams{"duplicate_key.yaml", 9, "a11_Pa", "duplicate key (first given on line 4)"}),
    [](const ::testing::TestParamInfo<BadParams>& param_info) {
      std::string name = param_info.param.file;
      return name.substr(0, name.find('.'));
    });

TEST(ParamsIo, MissingFile) {
  try {
    read_params_file(kFixtures + "does_not_exist.yaml");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("does_not_exist.yaml: cannot open file"), std::string::npos) << e.what();
  }
}

TEST(ParamsIo, ValidateParametersInCode) {
  MaterialParameters p;
  EXPECT_NO_THROW(validate_parameters(p, "code"));
  p.eta4 = Curve{{0.5, 0.4}, {1.0, 2.0}};
  try {
    validate_parameters(p, "code");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().key, "eta4.mu");
    EXPECT_NE(std::string(e.what()).find("sum to 0.9"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace twill
