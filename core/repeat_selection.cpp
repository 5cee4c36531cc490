#include "core/repeat_selection.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>

#include "core/input_error.hpp"
#include "core/yaml_reader.hpp"

namespace twill {
namespace {

std::uint64_t fnv1a(const std::string& text) {
  std::uint64_t h = 14695981039346656037ull;
  for (unsigned char c : text) {
    h ^= c;
    h *= 1099511628211ull;
  }
  return h;
}

// Vigna's splitmix64 finaliser: spreads nearby seeds over the whole 64-bit range.
std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

std::pair<double, double> loading_range(const TensileRun& run) {
  const auto begin = run.extension_mm.begin();
  const auto end = begin + static_cast<std::ptrdiff_t>(run.peak_index) + 1;
  const auto [lo, hi] = std::minmax_element(begin, end);
  return {*lo, *hi};
}

RepeatSelection largest(const TensileTest& test) {
  RepeatSelection s;
  double lo = -INFINITY, hi = INFINITY;
  for (const auto& run : test.runs) {
    const auto [a, b] = loading_range(run);
    lo = std::max(lo, a);
    hi = std::min(hi, b);
  }
  if (!(hi > lo))
    throw InputError({test.runs.front().path, 0, ""},
                     "the runs of tensile test '" + test.label +
                         "' share no extension range, so the run with the largest forces is undefined");
  s.common_min_mm = lo;
  s.common_max_mm = hi;
  std::size_t best = 0;
  for (std::size_t r = 0; r < test.runs.size(); ++r) {
    s.force_integral_Nmm.push_back(loading_force_integral(test.runs[r], lo, hi));
    if (s.force_integral_Nmm[r] > s.force_integral_Nmm[best]) best = r;
  }
  s.runs = {best};
  s.reason = "largest forces: " + test.runs[best].name() + " (integral of force " +
             format_double(std::round(s.force_integral_Nmm[best] * 1000) / 1000) + " N·mm over " +
             format_double(lo) + "–" + format_double(hi) + " mm, the range all " +
             std::to_string(test.runs.size()) + " runs share)";
  return s;
}

// `seed_text` says where the engine's seed came from, for the report.
RepeatSelection random(const TensileTest& test, std::uint64_t engine_seed, const std::string& seed_text) {
  std::mt19937_64 engine(engine_seed);
  // engine() % n rather than uniform_int_distribution: same draw on every standard library;
  // the modulo bias is below n / 2^64.
  const std::size_t pick = static_cast<std::size_t>(engine() % test.runs.size());
  RepeatSelection s;
  s.runs = {pick};
  s.reason = "random: " + test.runs[pick].name() + " (one of " + std::to_string(test.runs.size()) + ", " +
             seed_text + ")";
  return s;
}

RepeatSelection every_run(const TensileTest& test) {
  RepeatSelection s;
  s.runs.resize(test.runs.size());
  std::iota(s.runs.begin(), s.runs.end(), std::size_t{0});
  s.reason = "all " + std::to_string(test.runs.size()) + " runs";
  return s;
}

RepeatSelection select(const TensileTest& test, RepeatRule rule, std::uint64_t engine_seed,
                       const std::string& seed_text) {
  if (test.runs.empty()) throw InputError({}, "tensile test '" + test.label + "' has no runs");
  switch (rule) {
    case RepeatRule::All: return every_run(test);
    case RepeatRule::Largest: return largest(test);
    case RepeatRule::Random: return random(test, engine_seed, seed_text);
    case RepeatRule::Paper:
      return is_principal_direction(test.angle_deg) ? largest(test) : random(test, engine_seed, seed_text);
    case RepeatRule::LargestOrAll: return is_principal_direction(test.angle_deg) ? largest(test) : every_run(test);
  }
  return {};
}

constexpr RepeatRule kEveryRule[] = {RepeatRule::Paper, RepeatRule::Largest, RepeatRule::Random, RepeatRule::All,
                                     RepeatRule::LargestOrAll};

}  // namespace

const char* to_string(RepeatRule rule) {
  switch (rule) {
    case RepeatRule::Paper: return "paper";
    case RepeatRule::Largest: return "largest";
    case RepeatRule::Random: return "random";
    case RepeatRule::All: return "all";
    case RepeatRule::LargestOrAll: return "largest-or-all";
  }
  return "";
}

std::vector<std::pair<std::string, RepeatRule>> repeat_rule_names() {
  std::vector<std::pair<std::string, RepeatRule>> names;
  for (RepeatRule r : kEveryRule) names.emplace_back(to_string(r), r);
  return names;
}

RepeatRule repeat_rule_from_string(const std::string& name) {
  std::string known;
  for (RepeatRule r : kEveryRule) {
    if (name == to_string(r)) return r;
    known += (known.empty() ? "" : ", ") + std::string(to_string(r));
  }
  throw InputError({}, "unknown repeat rule '" + name + "' (known: " + known + ")");
}

bool is_principal_direction(double angle_deg) {
  const double r = std::fmod(std::abs(angle_deg), 90.0);
  return r < 1e-9 || 90.0 - r < 1e-9;
}

double loading_force_integral(const TensileRun& run, double from_mm, double to_mm) {
  // Loading branch sorted by extension (stable: a held crosshead may repeat an extension).
  std::vector<std::size_t> order(run.peak_index + 1);
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return run.extension_mm[a] < run.extension_mm[b]; });
  double integral = 0.0;
  for (std::size_t k = 0; k + 1 < order.size(); ++k) {
    const double x0 = run.extension_mm[order[k]], x1 = run.extension_mm[order[k + 1]];
    const double f0 = run.force_N[order[k]], f1 = run.force_N[order[k + 1]];
    const double a = std::max(x0, from_mm), b = std::min(x1, to_mm);
    if (!(b > a) || !(x1 > x0)) continue;
    // Exact integral of the linear interpolant over [a, b] (trapezoid of its end values).
    const double fa = f0 + (f1 - f0) * (a - x0) / (x1 - x0);
    const double fb = f0 + (f1 - f0) * (b - x0) / (x1 - x0);
    integral += 0.5 * (fa + fb) * (b - a);
  }
  return integral;
}

RepeatSelection select_repeats(const TensileTest& test, RepeatRule rule, std::uint64_t seed) {
  return select(test, rule, seed, "seed " + std::to_string(seed));
}

std::vector<RepeatSelection> select_repeats(const Dataset& dataset, RepeatRule rule, std::uint64_t seed) {
  std::vector<RepeatSelection> out;
  for (const auto& test : dataset.tensile)
    out.push_back(select(test, rule, splitmix64(seed ^ fnv1a(test.label)),
                         "seed " + std::to_string(seed) + " mixed with the label '" + test.label + "'"));
  return out;
}

}  // namespace twill
