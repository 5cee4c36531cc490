// Reading, expanding and validating a study file (study/study_file.hpp).
#include "study/study_file.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <map>

#include "core/dataset.hpp"
#include "core/registry.hpp"
#include "core/yaml_reader.hpp"
#include "fitting/fit_config.hpp"
#include "fitting/fit_input_checks.hpp"
#include "fitting/fit_protocol.hpp"

namespace twill {
namespace {

namespace fs = std::filesystem;

/// One config override of a run, with the study-file line it came from.
struct Assignment {
  std::string key, value;
  InputLocation where;
};

const std::vector<std::string> kStudyKeys = {"command", "datasets", "config", "vary", "combinations", "set", "plots", "report"};

// A YAML value as the text `--set` reads back: scalars as written, lists and mappings in flow
// style (`[hysteresis]`, `{name: bfgs}`).
std::string yaml_text(const YAML::Node& node) {
  if (node.IsScalar()) return node.Scalar();
  YAML::Emitter out;
  out.SetSeqFormat(YAML::Flow);
  out.SetMapFormat(YAML::Flow);
  out << node;
  return out.c_str();
}

// A mapping of config keys to single values (`set`, one entry of `combinations`).
std::vector<Assignment> read_assignments(const YamlValue& value) {
  YamlMap map(value);
  std::vector<Assignment> out;
  for (const std::string& key : map.keys()) {
    const YamlValue v = map.get(key);
    out.push_back({key, yaml_text(v.node()), v.location()});
  }
  map.finish();
  return out;
}

// `vary`: every config key with a non-empty list of values; their product, in file order with
// the last key varying fastest.
std::vector<std::vector<Assignment>> product_of(const YamlValue& vary) {
  YamlMap map(vary);
  std::vector<std::vector<Assignment>> combinations(1);
  for (const std::string& key : map.keys()) {
    const YamlValue list = map.get(key);
    if (!list.is_sequence() || list.items().empty())
      throw list.error("expected a non-empty list of values for the config key '" + excerpt(key) + "', got " +
                       list.describe());
    std::vector<std::vector<Assignment>> next;
    for (const std::vector<Assignment>& partial : combinations)
      for (const YamlValue& item : list.items()) {
        next.push_back(partial);
        next.back().push_back({key, yaml_text(item.node()), item.location()});
      }
    combinations = std::move(next);
  }
  map.finish();
  return combinations;
}

std::vector<std::vector<Assignment>> read_combinations(YamlMap& study) {
  const auto vary = study.find("vary");
  const auto listed = study.find("combinations");
  if (vary && listed)
    throw listed->error("give either vary (their product is run) or combinations (each is run), not both");
  if (vary) return product_of(*vary);
  if (!listed) return {{}};  // every dataset once, with the base config
  if (!listed->is_sequence() || listed->items().empty())
    throw listed->error("expected a non-empty list of mappings (config key: value), got " + listed->describe());
  std::vector<std::vector<Assignment>> out;
  for (const YamlValue& item : listed->items()) out.push_back(read_assignments(item));
  return out;
}

// The datasets, resolved against the study file's folder, each checked to be a folder here.
std::vector<std::pair<std::string, std::string>> read_datasets(YamlMap& study, const fs::path& folder) {
  const YamlValue list = study.get("datasets");
  if (!list.is_sequence() || list.items().empty())
    throw list.error("expected a non-empty list of dataset folders, got " + list.describe());
  std::vector<std::pair<std::string, std::string>> out;  // (as written, resolved)
  for (const YamlValue& item : list.items()) {
    const std::string written = item.as_string();
    const fs::path resolved = fs::path(written).is_absolute() ? fs::path(written) : folder / written;
    std::error_code ec;
    if (!fs::is_directory(resolved, ec))
      throw item.error("dataset folder '" + excerpt(resolved.string()) +
                       "' does not exist or is not a folder (relative paths are read from the study file's folder)");
    out.emplace_back(written, resolved.lexically_normal().string());
  }
  return out;
}

// Where a run's config key got its value: its last assignment that sets it, else the base
// config file, else the defaults.
InputLocation locate_key(const std::vector<Assignment>& assignments, const std::string& base,
                         const std::string& key) {
  for (auto it = assignments.rbegin(); it != assignments.rend(); ++it)
    if (override_sets_key(it->key, key)) return {it->where.file, it->where.line, key};
  return {base.empty() ? "default config" : base, 0, key};
}

Options run_config(const Options& base, const std::vector<Assignment>& assignments, const Registry& registry) {
  static const OptionSchema schema = fit_config_schema();
  Options config = base;
  for (const Assignment& a : assignments) {
    try {
      apply_override(config, schema, &registry, a.key + "=" + a.value);
    } catch (const InputError& e) {
      const std::string hint = moved_key_hint(e.where().key);
      throw InputError(a.where, "config key '" + excerpt(a.key) + "': " + e.reason() + (hint.empty() ? "" : "; " + hint));
    }
  }
  return config;
}

std::string run_hash(const std::string& command, const std::string& dataset, const Options& config) {
  const std::string text = command + "\n" + fs::absolute(dataset).lexically_normal().string() + "\n" +
                           options_to_yaml(config);
  std::uint64_t h = 14695981039346656037ull;  // FNV-1a 64: offset basis and prime
  for (const unsigned char c : text) {
    h ^= c;
    h *= 1099511628211ull;
  }
  return fmt::format("{:016x}", h);
}

// The keys a report can tabulate against: "dataset" and every key a run varies.
std::vector<std::string> swept_keys(const std::vector<std::vector<Assignment>>& combinations) {
  std::vector<std::string> keys = {"dataset"};
  for (const auto& combination : combinations)
    for (const Assignment& a : combination)
      if (std::find(keys.begin(), keys.end(), a.key) == keys.end()) keys.push_back(a.key);
  return keys;
}

std::string read_swept_key(const YamlValue& value, const std::vector<std::string>& swept) {
  const std::string key = value.as_string();
  if (std::find(swept.begin(), swept.end(), key) == swept.end())
    throw value.error("'" + excerpt(key) + "' is not a swept key of this study (swept: " + fmt::format("{}", fmt::join(swept, ", ")) + ")");
  return key;
}

// `report:` — a list of {metric, x, group}; x and group must be swept keys.
std::vector<ReportTable> read_report(const YamlValue& list, const std::vector<std::string>& swept) {
  if (!list.is_sequence() || list.items().empty())
    throw list.error("expected a non-empty list of tables ({metric: NAME, x: KEY, group: [KEYS]}), got " + list.describe());
  std::vector<ReportTable> out;
  for (const YamlValue& item : list.items()) {
    YamlMap map(item);
    map.expect({"metric", "x", "group"});
    ReportTable t;
    t.metric = map.get("metric").as_string();
    t.x = read_swept_key(map.get("x"), swept);
    if (const auto group = map.find("group")) {
      if (group->is_sequence())
        for (const YamlValue& g : group->items()) t.group.push_back(read_swept_key(g, swept));
      else
        t.group.push_back(read_swept_key(*group, swept));
    }
    map.finish();
    out.push_back(std::move(t));
  }
  return out;
}

}  // namespace

const std::vector<std::string>& study_commands() {
  static const std::vector<std::string> commands = {"fit"};
  return commands;
}

Study read_study_file(const std::string& path, const Registry& registry) {
  const YamlValue root = load_yaml_file(path);
  YamlMap study(root);
  study.expect(kStudyKeys);
  Study out;
  out.path = path;
  const fs::path folder = fs::path(path).parent_path();
  out.command = "fit";
  if (const auto command = study.find("command")) {
    out.command = command->as_string();
    const auto& known = study_commands();
    if (std::find(known.begin(), known.end(), out.command) == known.end())
      throw command->error("unknown command '" + excerpt(out.command) + "' (a study runs: fit; simulate and " +
                           "discover are not sweepable yet)");
  }
  if (const auto plots = study.find("plots")) out.plots = plots->as_bool();
  const auto datasets = read_datasets(study, folder);
  std::string base_file;
  Options base;
  if (const auto config = study.find("config")) {
    base_file = (folder / config->as_string()).string();
    check_readable_file(base_file, config->location());
    base = read_config_file(base_file, fit_config_schema(), &registry);
  } else {
    base = default_options(fit_config_schema(), &registry);
  }
  std::vector<Assignment> fixed;
  if (const auto set = study.find("set")) fixed = read_assignments(*set);
  const auto combinations = read_combinations(study);
  if (const auto report = study.find("report")) out.report = read_report(*report, swept_keys(combinations));
  study.finish();

  std::map<std::string, Dataset> read;  // each dataset read (and so validated) once
  for (const auto& [written, resolved] : datasets) {
    if (!read.count(resolved)) read.emplace(resolved, read_dataset(resolved));
    for (const std::vector<Assignment>& combination : combinations) {
      std::vector<Assignment> assignments = fixed;
      assignments.insert(assignments.end(), combination.begin(), combination.end());
      StudyRun run;
      run.dataset = resolved;
      run.values.emplace_back("dataset", written);
      for (const Assignment& a : combination) run.values.emplace_back(a.key, a.value);
      run.config = run_config(base, assignments, registry);
      const ConfigKeyLocator locate = [&](const std::string& key) { return locate_key(assignments, base_file, key); };
      check_fit_sizes(read.at(resolved), run.config, locate);
      check_fit_protocol(read.at(resolved), run.config, registry, locate);
      run.hash = run_hash(out.command, resolved, run.config);
      for (const StudyRun& earlier : out.runs)
        if (earlier.hash == run.hash)
          throw InputError(combination.empty() ? InputLocation{path, 0, "datasets"} : combination.back().where,
                           "two runs resolve to the same config (" + describe_run(earlier) + " and " +
                               describe_run(run) + "): a study runs each config once");
      out.runs.push_back(std::move(run));
    }
  }
  return out;
}

std::string describe_run(const StudyRun& run) {
  std::string line;
  for (const auto& [key, value] : run.values) line += (line.empty() ? "" : " ") + key + "=" + value;
  return line;
}

}  // namespace twill
