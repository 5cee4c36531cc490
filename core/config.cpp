#include "core/config.hpp"

#include <cmath>
#include <fstream>
#include <regex>
#include <stdexcept>

#include "core/registry.hpp"

namespace twill {
namespace {

const char* const kOverrideSource = "--set";

template <typename T>
const char* type_name_of() {
  if constexpr (std::is_same_v<T, bool>) return "bool";
  else if constexpr (std::is_same_v<T, std::int64_t>) return "int";
  else if constexpr (std::is_same_v<T, double>) return "double";
  else if constexpr (std::is_same_v<T, std::string>) return "string";
  else if constexpr (std::is_same_v<T, std::vector<double>>) return "list of doubles";
  else if constexpr (std::is_same_v<T, Options>) return "section";
  else if constexpr (std::is_same_v<T, ComponentChoice>) return "component";
  else return "component list";
}

const char* held_type_name(const OptionValue& v) {
  return std::visit([](const auto& x) { return type_name_of<std::decay_t<decltype(x)>>(); }, v);
}

std::size_t expected_index(OptionType type) {
  switch (type) {
    case OptionType::Bool: return 0;
    case OptionType::Int: return 1;
    case OptionType::Double: return 2;
    case OptionType::String: return 3;
    case OptionType::DoubleList: return 4;
    case OptionType::Section: return 5;
    case OptionType::Component: return 6;
    case OptionType::ComponentList: return 7;
  }
  return 0;
}

template <typename T>
const T& get_as(const Options& o, const std::string& key) {
  const OptionValue& v = o.value(key);
  if (const T* typed = std::get_if<T>(&v)) return *typed;
  throw std::logic_error(std::string("config option '") + key + "' holds a " + held_type_name(v) + ", not a " +
                         type_name_of<T>());
}

std::string list_text(const std::vector<double>& values) {
  std::string out = "[";
  for (std::size_t i = 0; i < values.size(); ++i) out += (i ? ", " : "") + format_double(values[i]);
  return out + "]";
}

std::string trim(const std::string& s) {
  const auto begin = s.find_first_not_of(" \t");
  if (begin == std::string::npos) return {};
  const auto end = s.find_last_not_of(" \t");
  return s.substr(begin, end - begin + 1);
}

// ---- resolving -------------------------------------------------------------------------

Options resolve_in(const OptionSchema& schema, YamlMap* map, const InputLocation& where, const Registry* registry);

const RegistryEntry& entry_named(const std::string& category, const std::string& name, const InputLocation& where,
                                 const Registry* registry) {
  if (!registry)
    throw std::logic_error("config: resolving a '" + category + "' component needs a Registry (got nullptr)");
  const RegistryCategory* found = registry->find_category(category);
  const RegistryEntry* entry = found ? found->find(name) : nullptr;
  if (!entry)
    throw InputError(where, "unknown " + category + " '" + name + "' (known: " +
                                (found ? found->known_names() : std::string("none registered")) + ")");
  return *entry;
}

ComponentChoice component_defaults(const std::string& category, const std::string& name, const InputLocation& where,
                                   const Registry* registry) {
  const RegistryEntry& entry = entry_named(category, name, where, registry);
  return ComponentChoice{category, name, resolve_in(entry.options, nullptr, where, registry)};
}

ComponentChoice resolve_component(const std::string& category, const std::string& default_name, const YamlValue& v,
                                  const Registry* registry) {
  if (v.is_null()) {
    if (default_name.empty()) throw v.error("a " + category + " name is required");
    return component_defaults(category, default_name, v.location(), registry);
  }
  if (v.is_scalar()) return component_defaults(category, v.as_string(), v.location(), registry);
  if (!v.is_map())
    throw v.error("expected a " + category + " name or a mapping {name: ..., options...}, got " + v.describe());
  YamlMap map(v);
  map.has("name");  // the selector is a known key of every component mapping
  std::string name = default_name;
  InputLocation name_where = v.location();
  if (auto given = map.find("name")) {
    name = given->as_string();
    name_where = given->location();
  } else if (name.empty()) {
    throw InputError({v.file(), v.line(), map.child_path("name")}, "missing required key (which " + category + ")");
  }
  const RegistryEntry& entry = entry_named(category, name, name_where, registry);
  ComponentChoice choice{category, name, resolve_in(entry.options, &map, v.location(), registry)};
  map.finish();
  return choice;
}

void check_value(const OptionSpec& spec, const OptionValue& value, const YamlValue& v) {
  const std::string problem = spec.violation(value);
  if (!problem.empty()) throw v.error(problem);
}

OptionValue resolve_value(const OptionSpec& spec, const YamlValue& v, const Registry* registry) {
  OptionValue out;
  switch (spec.type) {
    case OptionType::Bool: out = v.as_bool(); break;
    case OptionType::Int: out = v.as_int(); break;
    case OptionType::Double: out = v.as_double(); break;
    case OptionType::String: out = v.as_string(); break;
    case OptionType::DoubleList: out = v.as_double_list(); break;
    case OptionType::Section:
      if (v.is_null()) {
        out = resolve_in(*spec.section, nullptr, v.location(), registry);
      } else {
        YamlMap map(v);
        out = resolve_in(*spec.section, &map, v.location(), registry);
        map.finish();
      }
      break;
    case OptionType::Component:
      out = resolve_component(spec.category, std::get<std::string>(spec.default_value), v, registry);
      break;
    case OptionType::ComponentList: {
      std::vector<ComponentChoice> list;
      if (!v.is_null())
        for (const auto& item : v.items()) list.push_back(resolve_component(spec.category, "", item, registry));
      out = std::move(list);
      break;
    }
  }
  check_value(spec, out, v);
  return out;
}

OptionValue absent_value(const OptionSpec& spec, const InputLocation& where, const Registry* registry) {
  const InputLocation here{where.file, where.line, join_key_path(where.key, spec.name)};
  if (spec.is_required) throw InputError(here, "missing required key");
  switch (spec.type) {
    case OptionType::Bool: return std::get<bool>(spec.default_value);
    case OptionType::Int: return std::get<std::int64_t>(spec.default_value);
    case OptionType::Double: return std::get<double>(spec.default_value);
    case OptionType::String: return std::get<std::string>(spec.default_value);
    case OptionType::DoubleList: return std::get<std::vector<double>>(spec.default_value);
    case OptionType::Section: return resolve_in(*spec.section, nullptr, here, registry);
    case OptionType::Component: {
      const auto& name = std::get<std::string>(spec.default_value);
      return component_defaults(spec.category, name, here, registry);
    }
    case OptionType::ComponentList: {
      if (spec.default_items_yaml.empty()) return std::vector<ComponentChoice>{};
      const YamlValue items = load_yaml_string(spec.default_items_yaml, spec.default_items_source);
      return resolve_value(spec, items, registry);
    }
  }
  return {};
}

Options resolve_in(const OptionSchema& schema, YamlMap* map, const InputLocation& where, const Registry* registry) {
  if (map) {
    std::vector<std::string> names;
    for (const OptionSpec& spec : schema.options()) names.push_back(spec.name);
    map->expect(names);  // unknown keys first: a misspelt key is named, not the one it hides
  }
  Options out;
  for (const OptionSpec& spec : schema.options()) {
    std::optional<YamlValue> given = map ? map->find(spec.name) : std::nullopt;
    OptionValue value = given ? resolve_value(spec, *given, registry) : absent_value(spec, where, registry);
    out.set(spec.name, std::move(value));
  }
  return out;
}

// ---- overrides -------------------------------------------------------------------------

struct PathSegment {
  std::string name;
  std::optional<std::size_t> index;
  bool every = false;  ///< name[*]: every entry of a component list that has the next key
};

std::vector<PathSegment> parse_path(const std::string& path) {
  std::vector<PathSegment> out;
  std::size_t start = 0;
  while (true) {
    const auto dot = path.find('.', start);
    std::string part = path.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
    PathSegment seg;
    const auto bracket = part.find('[');
    if (bracket != std::string::npos) {
      const auto close = part.find(']', bracket);
      const std::string digits = close == std::string::npos ? "" : part.substr(bracket + 1, close - bracket - 1);
      seg.every = digits == "*";
      if (close != part.size() - 1 || digits.empty() ||
          (!seg.every && digits.find_first_not_of("0123456789") != std::string::npos))
        throw InputError({kOverrideSource, 0, path},
                         "malformed key path: '" + part + "' (expected name, name[i] or name[*])");
      if (!seg.every) seg.index = static_cast<std::size_t>(std::stoull(digits));
      part = part.substr(0, bracket);
    }
    if (part.empty()) throw InputError({kOverrideSource, 0, path}, "malformed key path: empty key");
    seg.name = part;
    out.push_back(seg);
    if (dot == std::string::npos) break;
    start = dot + 1;
  }
  return out;
}

struct Override {
  std::vector<PathSegment> segments;
  std::string text;  // the value as given
  const Registry* registry;

  std::string path_to(std::size_t i) const {
    std::string p;
    for (std::size_t k = 0; k <= i; ++k) {
      p = join_key_path(p, segments[k].name);
      if (segments[k].index) p += "[" + std::to_string(*segments[k].index) + "]";
      if (segments[k].every) p += "[*]";
    }
    return p;
  }
  InputError error(std::size_t i, const std::string& what) const {
    return InputError({kOverrideSource, 0, path_to(i)}, what);
  }

  void switch_component(ComponentChoice& c, std::size_t i) const {
    const std::string name = trim(text);
    c = component_defaults(c.category, name, {kOverrideSource, 0, path_to(i)}, registry);
  }

  void apply_to_component(ComponentChoice& c, std::size_t i) const {
    if (i + 1 == segments.size()) return switch_component(c, i);
    const PathSegment& next = segments[i + 1];
    if (next.name == "name" && !next.index && i + 2 == segments.size()) return switch_component(c, i + 1);
    const RegistryEntry& entry = entry_named(c.category, c.name, {kOverrideSource, 0, path_to(i)}, registry);
    apply(c.options, entry.options, i + 1);
  }

  /// list[*].key=value: the key of every entry that has it (a list of stages of several kinds
  /// sets one rule in each stage that has it); an error when none has it.
  void apply_to_every(std::vector<ComponentChoice>& list, std::size_t i) const {
    if (i + 1 == segments.size()) throw error(i, "[*] needs a key after it, e.g. " + segments[i].name + "[*].key=value");
    const PathSegment& next = segments[i + 1];
    if (next.name == "name") throw error(i + 1, "[*] cannot switch every entry's implementation; address one as [i]");
    std::size_t applied = 0;
    for (ComponentChoice& c : list) {
      const RegistryEntry& entry = entry_named(c.category, c.name, {kOverrideSource, 0, path_to(i)}, registry);
      if (!entry.options.find(next.name)) continue;
      apply(c.options, entry.options, i + 1);
      ++applied;
    }
    if (applied == 0) throw error(i + 1, "no entry of " + segments[i].name + " has this key");
  }

  void apply(Options& options, const OptionSchema& schema, std::size_t i) const {
    const PathSegment& seg = segments[i];
    const OptionSpec* spec = schema.find(seg.name);
    if (!spec) throw error(i, "unknown key (known keys here: " + schema.names() + ")");
    const bool last = i + 1 == segments.size();
    if ((seg.index || seg.every) && spec->type != OptionType::ComponentList)
      throw error(i, std::string("is of type ") + to_string(spec->type) + ", not a list of components: no [index]");
    OptionValue& slot = options.value(seg.name);
    switch (spec->type) {
      case OptionType::Section:
        if (last) throw error(i, "is a section; set one of its keys (" + spec->section->names() + ")");
        return apply(std::get<Options>(slot), *spec->section, i + 1);
      case OptionType::Component: return apply_to_component(std::get<ComponentChoice>(slot), i);
      case OptionType::ComponentList: {
        auto& list = std::get<std::vector<ComponentChoice>>(slot);
        if (seg.every) return apply_to_every(list, i);
        if (!seg.index && last) {  // the whole list, as YAML: effects=[misalignment, {name: x, k: 1}]
          const YamlValue parsed = load_yaml_string(text, kOverrideSource);
          slot = resolve_value(*spec, YamlValue(parsed.node(), kOverrideSource, path_to(i)), registry);
          return;
        }
        if (!seg.index) throw error(i, "is a list of components; address one as " + seg.name + "[i]");
        if (*seg.index >= list.size())
          throw error(i, "has " + std::to_string(list.size()) + " entries; index " + std::to_string(*seg.index) +
                             " is out of range");
        return apply_to_component(list[*seg.index], i);
      }
      default: break;
    }
    if (!last) throw error(i, std::string("is of type ") + to_string(spec->type) + " and has no keys below it");
    if (spec->type == OptionType::String) {
      // Verbatim: YAML would turn "#tag" into a comment and "a: b" into a mapping.
      OptionValue value = text;
      const std::string problem = spec->violation(value);
      if (!problem.empty()) throw error(i, problem);
      slot = std::move(value);
      return;
    }
    const YamlValue parsed = load_yaml_string(text, kOverrideSource);
    slot = resolve_value(*spec, YamlValue(parsed.node(), kOverrideSource, path_to(i)), registry);
  }
};

// ---- writing ---------------------------------------------------------------------------

void emit(YAML::Emitter& out, const Options& options);

void emit_value(YAML::Emitter& out, const OptionValue& value) {
  std::visit(
      [&](const auto& x) {
        using T = std::decay_t<decltype(x)>;
        if constexpr (std::is_same_v<T, bool>) {
          out << (x ? "true" : "false");
        } else if constexpr (std::is_same_v<T, std::int64_t>) {
          out << std::to_string(x);
        } else if constexpr (std::is_same_v<T, double>) {
          out << format_double(x);
        } else if constexpr (std::is_same_v<T, std::string>) {
          out << YAML::DoubleQuoted << x;
        } else if constexpr (std::is_same_v<T, std::vector<double>>) {
          out << YAML::Flow << YAML::BeginSeq;
          for (double d : x) out << format_double(d);
          out << YAML::EndSeq;
        } else if constexpr (std::is_same_v<T, Options>) {
          emit(out, x);
        } else if constexpr (std::is_same_v<T, ComponentChoice>) {
          out << YAML::BeginMap << YAML::Key << "name" << YAML::Value << YAML::DoubleQuoted << x.name;
          for (const auto& e : x.options.entries()) {
            out << YAML::Key << e.key << YAML::Value;
            emit_value(out, e.value);
          }
          out << YAML::EndMap;
        } else {
          if (x.empty()) {
            out << YAML::Flow << YAML::BeginSeq << YAML::EndSeq;
          } else {
            out << YAML::BeginSeq;
            for (const auto& c : x) emit_value(out, OptionValue(c));
            out << YAML::EndSeq;
          }
        }
      },
      value);
}

void emit(YAML::Emitter& out, const Options& options) {
  if (options.empty()) {
    out << YAML::Flow << YAML::BeginMap << YAML::EndMap;
    return;
  }
  out << YAML::BeginMap;
  for (const auto& e : options.entries()) {
    out << YAML::Key << e.key << YAML::Value;
    emit_value(out, e.value);
  }
  out << YAML::EndMap;
}

}  // namespace

const char* to_string(OptionType type) {
  switch (type) {
    case OptionType::Bool: return "bool";
    case OptionType::Int: return "int";
    case OptionType::Double: return "double";
    case OptionType::String: return "string";
    case OptionType::DoubleList: return "list of doubles";
    case OptionType::Section: return "section";
    case OptionType::Component: return "component";
    case OptionType::ComponentList: return "component list";
  }
  return "";
}

// ---- Options ---------------------------------------------------------------------------

const OptionEntry* Options::find(const std::string& key) const {
  for (const auto& e : entries_)
    if (e.key == key) return &e;
  return nullptr;
}

OptionEntry* Options::find(const std::string& key) {
  for (auto& e : entries_)
    if (e.key == key) return &e;
  return nullptr;
}

bool Options::has(const std::string& key) const { return find(key) != nullptr; }

const OptionValue& Options::value(const std::string& key) const {
  if (const OptionEntry* e = find(key)) return e->value;
  std::string present;
  for (const auto& e : entries_) present += (present.empty() ? "" : ", ") + e.key;
  throw std::logic_error("config option '" + key + "' is not present (present: " + present + ")");
}

OptionValue& Options::value(const std::string& key) {
  return const_cast<OptionValue&>(static_cast<const Options&>(*this).value(key));
}

bool Options::get_bool(const std::string& key) const { return get_as<bool>(*this, key); }
std::int64_t Options::get_int(const std::string& key) const { return get_as<std::int64_t>(*this, key); }
double Options::get_double(const std::string& key) const { return get_as<double>(*this, key); }
const std::string& Options::get_string(const std::string& key) const { return get_as<std::string>(*this, key); }
const std::vector<double>& Options::get_double_list(const std::string& key) const {
  return get_as<std::vector<double>>(*this, key);
}
const Options& Options::get_section(const std::string& key) const { return get_as<Options>(*this, key); }
const ComponentChoice& Options::get_component(const std::string& key) const {
  return get_as<ComponentChoice>(*this, key);
}
const std::vector<ComponentChoice>& Options::get_component_list(const std::string& key) const {
  return get_as<std::vector<ComponentChoice>>(*this, key);
}

bool Options::operator==(const Options& other) const { return entries_ == other.entries_; }

// ---- OptionSchema ----------------------------------------------------------------------

OptionSpec& OptionSchema::add(OptionSpec spec) {
  if (spec.name.empty()) throw std::logic_error("option schema: an option needs a name");
  if (spec.name.find_first_of(".[]= ") != std::string::npos)
    throw std::logic_error("option schema: '" + spec.name + "' may not contain '.', '[', ']', '=' or spaces");
  if (find(spec.name)) throw std::logic_error("option schema: '" + spec.name + "' is defined twice");
  if (spec.doc.empty() || spec.doc.find('\n') != std::string::npos)
    throw std::logic_error("option schema: '" + spec.name + "' needs a one-line doc");
  options_.push_back(std::move(spec));
  return options_.back();
}

OptionSpec& OptionSchema::add_bool(const std::string& name, bool default_value, const std::string& doc) {
  OptionSpec s;
  s.name = name;
  s.type = OptionType::Bool;
  s.doc = doc;
  s.default_value = default_value;
  return add(std::move(s));
}

OptionSpec& OptionSchema::add_int(const std::string& name, std::int64_t default_value, const std::string& doc) {
  OptionSpec s;
  s.name = name;
  s.type = OptionType::Int;
  s.doc = doc;
  s.default_value = default_value;
  return add(std::move(s));
}

OptionSpec& OptionSchema::add_double(const std::string& name, double default_value, const std::string& doc) {
  if (!std::isfinite(default_value))
    throw std::logic_error("option schema: '" + name + "' default must be finite (config doubles are)");
  OptionSpec s;
  s.name = name;
  s.type = OptionType::Double;
  s.doc = doc;
  s.default_value = default_value;
  return add(std::move(s));
}

OptionSpec& OptionSchema::add_string(const std::string& name, const std::string& default_value,
                                     const std::string& doc) {
  OptionSpec s;
  s.name = name;
  s.type = OptionType::String;
  s.doc = doc;
  s.default_value = default_value;
  return add(std::move(s));
}

OptionSpec& OptionSchema::add_double_list(const std::string& name, std::vector<double> default_value,
                                          const std::string& doc) {
  OptionSpec s;
  s.name = name;
  s.type = OptionType::DoubleList;
  s.doc = doc;
  s.default_value = std::move(default_value);
  return add(std::move(s));
}

OptionSchema& OptionSchema::add_section(const std::string& name, const std::string& doc) {
  OptionSpec s;
  s.name = name;
  s.type = OptionType::Section;
  s.doc = doc;
  s.section = std::make_shared<OptionSchema>();
  return *add(std::move(s)).section;
}

OptionSpec& OptionSchema::add_component(const std::string& name, const std::string& category,
                                        const std::string& default_name, const std::string& doc) {
  OptionSpec s;
  s.name = name;
  s.type = OptionType::Component;
  s.doc = doc;
  s.category = category;
  s.default_value = default_name;
  s.is_required = default_name.empty();
  return add(std::move(s));
}

OptionSpec& OptionSchema::add_component_list(const std::string& name, const std::string& category,
                                             const std::string& doc) {
  OptionSpec s;
  s.name = name;
  s.type = OptionType::ComponentList;
  s.doc = doc;
  s.category = category;
  return add(std::move(s));
}

const OptionSpec* OptionSchema::find(const std::string& name) const {
  for (const auto& s : options_)
    if (s.name == name) return &s;
  return nullptr;
}

std::string OptionSchema::names() const {
  std::string out;
  for (const auto& s : options_) out += (out.empty() ? "" : ", ") + s.name;
  return out.empty() ? "none" : out;
}

// ---- OptionSpec ------------------------------------------------------------------------

namespace {

void require_numeric(const OptionSpec& s, const char* what) {
  if (s.type != OptionType::Int && s.type != OptionType::Double && s.type != OptionType::DoubleList)
    throw std::logic_error(std::string("option schema: ") + what + " on '" + s.name + "', a " + to_string(s.type));
}

OptionValue default_as_value(const OptionSpec& s) {
  return std::visit(
      [](const auto& x) -> OptionValue {
        using T = std::decay_t<decltype(x)>;
        if constexpr (std::is_same_v<T, std::monostate>)
          return Options{};
        else
          return x;
      },
      s.default_value);
}

OptionSpec& checked(OptionSpec& s) {
  const bool has_default = !s.is_required && !std::holds_alternative<std::monostate>(s.default_value);
  if (has_default && s.type != OptionType::Component) {
    const std::string problem = s.violation(default_as_value(s));
    if (!problem.empty())
      throw std::logic_error("option schema: default of '" + s.name + "' violates its constraint: " + problem);
  }
  return s;
}

bool below(double x, double lo, bool exclusive) { return exclusive ? !(x > lo) : !(x >= lo); }
bool above(double x, double hi, bool exclusive) { return exclusive ? !(x < hi) : !(x <= hi); }

}  // namespace

OptionSpec& OptionSpec::at_least(double lo) {
  require_numeric(*this, "at_least");
  min = lo;
  min_exclusive = false;
  return checked(*this);
}

OptionSpec& OptionSpec::greater_than(double lo) {
  require_numeric(*this, "greater_than");
  min = lo;
  min_exclusive = true;
  return checked(*this);
}

OptionSpec& OptionSpec::at_most(double hi) {
  require_numeric(*this, "at_most");
  max = hi;
  max_exclusive = false;
  return checked(*this);
}

OptionSpec& OptionSpec::less_than(double hi) {
  require_numeric(*this, "less_than");
  max = hi;
  max_exclusive = true;
  return checked(*this);
}

OptionSpec& OptionSpec::range(double lo, double hi) {
  require_numeric(*this, "range");
  if (!(lo <= hi)) throw std::logic_error("option schema: empty range on '" + name + "'");
  min = lo;
  max = hi;
  min_exclusive = max_exclusive = false;
  return checked(*this);
}

OptionSpec& OptionSpec::choices(std::vector<std::string> values) {
  if (type != OptionType::String) throw std::logic_error("option schema: choices on non-string '" + name + "'");
  allowed = std::move(values);
  return checked(*this);
}

OptionSpec& OptionSpec::default_items(std::string yaml, std::string source) {
  if (type != OptionType::ComponentList) throw std::logic_error(name + ": default_items is for component lists");
  default_items_yaml = std::move(yaml);
  default_items_source = std::move(source);
  return *this;
}

OptionSpec& OptionSpec::non_empty() {
  if (type != OptionType::DoubleList && type != OptionType::ComponentList && type != OptionType::String)
    throw std::logic_error("option schema: non_empty on '" + name + "', a " + to_string(type));
  min_items = 1;
  return checked(*this);
}

OptionSpec& OptionSpec::required() {
  if (type == OptionType::Section) throw std::logic_error("option schema: a section cannot be required");
  is_required = true;
  if (type != OptionType::Component) default_value = std::monostate{};
  return *this;
}

std::string OptionSpec::constraint_text() const {
  std::string out;
  if (min && max) {
    out = std::string("in ") + (min_exclusive ? "(" : "[") + format_double(*min) + ", " + format_double(*max) +
          (max_exclusive ? ")" : "]");
  } else if (min) {
    out = std::string(min_exclusive ? "> " : ">= ") + format_double(*min);
  } else if (max) {
    out = std::string(max_exclusive ? "< " : "<= ") + format_double(*max);
  }
  if (!allowed.empty()) {
    out = "one of: ";
    for (std::size_t i = 0; i < allowed.size(); ++i) out += (i ? ", " : "") + allowed[i];
  }
  if (min_items > 0) {
    const char* ne = type == OptionType::String ? "not empty" : "at least one item";
    out = out.empty() ? ne : out + "; " + ne;
  }
  return out;
}

std::string OptionSpec::default_text() const {
  if (is_required) return "(required)";
  switch (type) {
    case OptionType::Bool: return std::get<bool>(default_value) ? "true" : "false";
    case OptionType::Int: return std::to_string(std::get<std::int64_t>(default_value));
    case OptionType::Double: return format_double(std::get<double>(default_value));
    case OptionType::String: {
      const auto& s = std::get<std::string>(default_value);
      return s.empty() ? "\"\"" : s;
    }
    case OptionType::DoubleList: return list_text(std::get<std::vector<double>>(default_value));
    case OptionType::Section: return "(section)";
    case OptionType::Component: return std::get<std::string>(default_value);
    case OptionType::ComponentList: return default_items_yaml.empty() ? "[]" : "(" + default_items_source + ")";
  }
  return "";
}

std::string OptionSpec::violation(const OptionValue& value) const {
  auto out_of_range = [&](double x) {
    return (min && below(x, *min, min_exclusive)) || (max && above(x, *max, max_exclusive));
  };
  if (const auto* i = std::get_if<std::int64_t>(&value)) {
    if (out_of_range(static_cast<double>(*i)))
      return "must be " + constraint_text() + ", got " + std::to_string(*i);
  } else if (const auto* d = std::get_if<double>(&value)) {
    if (out_of_range(*d)) return "must be " + constraint_text() + ", got " + format_double(*d);
  } else if (const auto* list = std::get_if<std::vector<double>>(&value)) {
    if (list->size() < min_items) return "needs at least " + std::to_string(min_items) + " item(s)";
    for (std::size_t k = 0; k < list->size(); ++k)
      if (out_of_range((*list)[k]))
        return "item [" + std::to_string(k) + "] must be " + constraint_text() + ", got " + format_double((*list)[k]);
  } else if (const auto* s = std::get_if<std::string>(&value)) {
    if (min_items > 0 && s->empty()) return "must not be empty";
    if (!allowed.empty()) {
      bool ok = false;
      for (const auto& a : allowed) ok = ok || a == *s;
      if (!ok) return "must be " + constraint_text() + "; got '" + *s + "'";
    }
  } else if (const auto* components = std::get_if<std::vector<ComponentChoice>>(&value)) {
    if (components->size() < min_items) return "needs at least " + std::to_string(min_items) + " item(s)";
  }
  return {};
}

// ---- free functions --------------------------------------------------------------------

Options resolve_options(const OptionSchema& schema, const YamlValue& value, const Registry* registry) {
  if (value.is_null()) return resolve_in(schema, nullptr, value.location(), registry);
  YamlMap map(value);
  Options out = resolve_in(schema, &map, value.location(), registry);
  map.finish();
  return out;
}

Options default_options(const OptionSchema& schema, const Registry* registry) {
  return resolve_in(schema, nullptr, InputLocation{}, registry);
}

Options read_config_file(const std::string& path, const OptionSchema& schema, const Registry* registry) {
  return resolve_options(schema, load_yaml_file(path), registry);
}

std::string with_every_index(const std::string& key) {
  static const std::regex index(R"(\[[0-9]+\])");
  return std::regex_replace(key, index, "[*]");
}

bool override_sets_key(const std::string& assigned, const std::string& key) {
  for (const std::string& k : {key, with_every_index(key)})
    if (k.rfind(assigned, 0) == 0 && (k.size() == assigned.size() || k[assigned.size()] == '.' || k[assigned.size()] == '['))
      return true;
  return false;
}

InputLocation command_line_key_location(const std::vector<std::string>& sets, const std::string& config_file,
                                        const std::string& key) {
  for (auto it = sets.rbegin(); it != sets.rend(); ++it) {
    const std::string assigned = trim(it->substr(0, it->find('=')));
    if (override_sets_key(assigned, key)) return {kOverrideSource, 0, key};
  }
  return {config_file.empty() ? "default config" : config_file, 0, key};
}

void apply_override(Options& config, const OptionSchema& schema, const Registry* registry,
                    const std::string& assignment) {
  const auto eq = assignment.find('=');
  if (eq == std::string::npos || trim(assignment.substr(0, eq)).empty())
    throw InputError({kOverrideSource, 0, ""}, "expected key.path=value, got '" + assignment + "'");
  const std::string path = trim(assignment.substr(0, eq));
  Override o{parse_path(path), trim(assignment.substr(eq + 1)), registry};
  o.apply(config, schema, 0);
}

void apply_overrides(Options& config, const OptionSchema& schema, const Registry* registry,
                     const std::vector<std::string>& assignments) {
  for (const auto& a : assignments) apply_override(config, schema, registry, a);
}

std::string options_to_yaml(const Options& options) {
  YAML::Emitter out;
  emit(out, options);
  return std::string("# resolved twill config: every option, defaults filled in\n") + out.c_str() + "\n";
}

void write_config_file(const Options& options, const std::string& path) {
  std::ofstream out(path, std::ios::binary);
  if (!out) throw std::runtime_error("cannot write config file " + path);
  out << options_to_yaml(options);
  if (!out.flush()) throw std::runtime_error("failed writing config file " + path);
}

void check_resolved_options(const OptionSchema& schema, const Options& options, const std::string& what) {
  for (const auto& spec : schema.options()) {
    if (!options.has(spec.name))
      throw std::logic_error(what + ": option '" + spec.name + "' is missing (resolve options against the schema)");
    const OptionValue& v = options.value(spec.name);
    if (v.index() != expected_index(spec.type))
      throw std::logic_error(what + ": option '" + spec.name + "' holds a " + held_type_name(v) + ", the schema says " +
                             to_string(spec.type));
  }
  for (const auto& e : options.entries())
    if (!schema.find(e.key)) throw std::logic_error(what + ": option '" + e.key + "' is not in the schema");
}

}  // namespace twill
