// Reading, expanding and validating a study file (study/study_file.hpp).
#include "study/study_file.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>

#include "core/dataset.hpp"
#include "core/registry.hpp"
#include "core/yaml_reader.hpp"
#include "fitting/fit_config.hpp"
#include "study/study_command.hpp"

namespace twill {
namespace {

namespace fs = std::filesystem;

/// One config override of a run, with the study-file line it came from.
struct Assignment {
  std::string key, value;
  InputLocation where;
};

const std::vector<std::string> kStudyKeys = {"command", "datasets", "params",       "config", "vary",
                                             "axes",    "combinations", "set", "plots", "report"};

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

// One run's share of the study's axes: its coordinates (swept key or axis name, value) and
// the config overrides they stand for.
struct Combination {
  std::vector<std::pair<std::string, std::string>> swept;
  std::vector<Assignment> sets;
};

// One dimension of the product: its values, each a coordinate and the overrides it sets.
using Dimension = std::vector<std::pair<std::string, std::vector<Assignment>>>;

// `vary`: every config key with a non-empty list of values, a dimension each.
std::vector<std::pair<std::string, Dimension>> vary_dimensions(const YamlValue& vary) {
  YamlMap map(vary);
  std::vector<std::pair<std::string, Dimension>> out;
  for (const std::string& key : map.keys()) {
    const YamlValue list = map.get(key);
    if (!list.is_sequence() || list.items().empty())
      throw list.error("expected a non-empty list of values for the config key '" + excerpt(key) + "', got " +
                       list.describe());
    Dimension d;
    for (const YamlValue& item : list.items())
      d.emplace_back(yaml_text(item.node()), std::vector<Assignment>{{key, yaml_text(item.node()), item.location()}});
    out.emplace_back(key, std::move(d));
  }
  map.finish();
  return out;
}

// `axes`: named dimensions whose values each set several config keys together, e.g.
// `degree: {1: {protocol[1].max_degree: 1, protocol[2].max_degree: 1}, 2: {...}}`.
std::vector<std::pair<std::string, Dimension>> axis_dimensions(const YamlValue& axes) {
  YamlMap map(axes);
  std::vector<std::pair<std::string, Dimension>> out;
  for (const std::string& name : map.keys()) {
    YamlMap values(map.get(name));
    if (values.keys().empty()) throw values.value().error("expected the axis '" + excerpt(name) + "' to have values");
    Dimension d;
    for (const std::string& label : values.keys()) d.emplace_back(label, read_assignments(values.get(label)));
    values.finish();
    out.emplace_back(name, std::move(d));
  }
  map.finish();
  return out;
}

// `combinations`, each run's coordinates and overrides listed; one empty one when absent.
std::vector<Combination> listed_combinations(const std::optional<YamlValue>& listed) {
  if (!listed) return {Combination{}};
  if (!listed->is_sequence() || listed->items().empty())
    throw listed->error("expected a non-empty list of mappings (config key: value), got " + listed->describe());
  std::vector<Combination> out;
  for (const YamlValue& item : listed->items()) {
    Combination c;
    c.sets = read_assignments(item);
    for (const Assignment& a : c.sets) c.swept.emplace_back(a.key, a.value);
    out.push_back(std::move(c));
  }
  return out;
}

// The study's runs per dataset: `combinations` (each listed run) crossed with the product of
// the `vary` keys and the `axes`, in file order with the last dimension varying fastest.
std::vector<Combination> read_combinations(YamlMap& study) {
  std::vector<std::pair<std::string, Dimension>> dimensions;
  if (const auto vary = study.find("vary")) dimensions = vary_dimensions(*vary);
  if (const auto axes = study.find("axes")) {
    auto more = axis_dimensions(*axes);
    for (auto& d : more) {
      for (const auto& [earlier, unused] : dimensions)
        if (earlier == d.first) throw axes->error("'" + excerpt(d.first) + "' is both a vary key and an axis");
      dimensions.push_back(std::move(d));
    }
  }
  std::vector<Combination> runs = listed_combinations(study.find("combinations"));
  for (const Combination& listed : runs)
    for (const Assignment& a : listed.sets)
      for (const auto& [name, unused] : dimensions)
        if (a.key == name) throw InputError(a.where, "'" + excerpt(name) + "' is both listed in combinations and varied");
  for (const auto& [name, dimension] : dimensions) {
    std::vector<Combination> next;
    for (const Combination& partial : runs)
      for (const auto& [value, sets] : dimension) {
        next.push_back(partial);
        next.back().swept.emplace_back(name, value);
        next.back().sets.insert(next.back().sets.end(), sets.begin(), sets.end());
      }
    runs = std::move(next);
  }
  return runs;
}

// The command's inputs (datasets or params files), resolved against the study file's folder,
// each checked to exist here as a folder or a file.
std::vector<std::pair<std::string, std::string>> read_inputs(YamlMap& study, const StudyCommand& command,
                                                             const fs::path& folder) {
  const std::string what = command.input_is_folder ? "folder" : "file";
  const std::string& noun = command.input_coordinate;
  const YamlValue list = study.get(command.input_key);
  if (!list.is_sequence() || list.items().empty())
    throw list.error("expected a non-empty list of " + noun + " " + what + "s, got " + list.describe());
  std::vector<std::pair<std::string, std::string>> out;  // (as written, resolved)
  for (const YamlValue& item : list.items()) {
    const std::string written = item.as_string();
    const fs::path resolved = fs::path(written).is_absolute() ? fs::path(written) : folder / written;
    std::error_code ec;
    if (command.input_is_folder ? !fs::is_directory(resolved, ec) : !fs::is_regular_file(resolved, ec))
      throw item.error(noun + " " + what + " '" + excerpt(resolved.string()) + "' does not exist or is not a " + what +
                       " (relative paths are read from the study file's folder)");
    out.emplace_back(written, resolved.lexically_normal().string());
  }
  return out;
}

// The other commands' input lists are not this study's.
void reject_other_inputs(YamlMap& study, const StudyCommand& command) {
  for (const StudyCommand& other : study_commands())
    if (other.input_key != command.input_key)
      if (const auto given = study.find(other.input_key))
        throw given->error("'" + other.input_key + "' is the input of `command: " + other.name + "`; this study runs " +
                           command.name + " on '" + command.input_key + "'");
}

// Where a run's config key got its value: its last assignment that sets it, else the base
// config file, else the defaults.
InputLocation locate_key(const std::vector<Assignment>& assignments, const std::string& base,
                         const std::string& key) {
  for (auto it = assignments.rbegin(); it != assignments.rend(); ++it)
    if (override_sets_key(it->key, key)) return {it->where.file, it->where.line, key};
  return {base.empty() ? "default config" : base, 0, key};
}

Options run_config(const OptionSchema& schema, const Options& base, const std::vector<Assignment>& assignments,
                   const Registry& registry) {
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

// The keys a report can tabulate against: the input ("dataset", "params") and every key a run varies.
std::vector<std::string> swept_keys(const std::string& input, const std::vector<Combination>& combinations) {
  std::vector<std::string> keys = {input};
  for (const Combination& combination : combinations)
    for (const auto& [key, value] : combination.swept)
      if (std::find(keys.begin(), keys.end(), key) == keys.end()) keys.push_back(key);
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
    throw list.error("expected a non-empty list of tables ({metric: NAME, x: KEY, group: [KEYS], convergence: BOOL}), got " + list.describe());
  std::vector<ReportTable> out;
  for (const YamlValue& item : list.items()) {
    YamlMap map(item);
    map.expect({"metric", "x", "group", "convergence"});
    ReportTable t;
    t.metric = map.get("metric").as_string();
    t.x = read_swept_key(map.get("x"), swept);
    if (const auto group = map.find("group")) {
      // The pseudo key `metric`: a column per metric the pattern matches (report.hpp).
      std::vector<std::string> groupable = swept;
      groupable.push_back("metric");
      if (group->is_sequence())
        for (const YamlValue& g : group->items()) t.group.push_back(read_swept_key(g, groupable));
      else
        t.group.push_back(read_swept_key(*group, groupable));
    }
    if (const auto convergence = map.find("convergence")) t.convergence = convergence->as_bool();
    map.finish();
    out.push_back(std::move(t));
  }
  return out;
}

}  // namespace

Study read_study_file(const std::string& path, const Registry& registry) {
  const YamlValue root = load_yaml_file(path);
  YamlMap study(root);
  study.expect(kStudyKeys);
  Study out;
  out.path = path;
  const fs::path folder = fs::path(path).parent_path();
  const StudyCommand* command = &study_commands().front();
  if (const auto given = study.find("command")) {
    command = find_study_command(given->as_string());
    if (!command) {
      std::string known;
      for (const StudyCommand& c : study_commands()) known += (known.empty() ? "" : ", ") + c.name;
      throw given->error("unknown command '" + excerpt(given->as_string()) + "' (a study runs: " + known +
                         "; discover is not sweepable yet)");
    }
  }
  out.command = command->name;
  if (const auto plots = study.find("plots")) out.plots = plots->as_bool();
  reject_other_inputs(study, *command);
  const auto inputs = read_inputs(study, *command, folder);
  const OptionSchema schema = command->schema();
  std::string base_file;
  Options base;
  if (const auto config = study.find("config")) {
    base_file = (folder / config->as_string()).string();
    check_readable_file(base_file, config->location());
    base = read_config_file(base_file, schema, &registry);
  } else {
    base = default_options(schema, &registry);
  }
  std::vector<Assignment> fixed;
  if (const auto set = study.find("set")) fixed = read_assignments(*set);
  const auto combinations = read_combinations(study);
  if (const auto report = study.find("report")) out.report = read_report(*report, swept_keys(command->input_coordinate, combinations));
  study.finish();

  for (const auto& [written, resolved] : inputs) {
    for (const Combination& combination : combinations) {
      std::vector<Assignment> assignments = fixed;
      assignments.insert(assignments.end(), combination.sets.begin(), combination.sets.end());
      StudyRun run;
      run.dataset = resolved;
      run.values.emplace_back(command->input_coordinate, written);
      run.values.insert(run.values.end(), combination.swept.begin(), combination.swept.end());
      run.config = run_config(schema, base, assignments, registry);
      const ConfigKeyLocator locate = [&](const std::string& key) { return locate_key(assignments, base_file, key); };
      command->check(resolved, run.config, registry, locate);
      run.hash = run_hash(out.command, resolved, run.config);
      for (const StudyRun& earlier : out.runs)
        if (earlier.hash == run.hash)
          throw InputError(combination.sets.empty() ? InputLocation{path, 0, command->input_key} : combination.sets.back().where,
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
