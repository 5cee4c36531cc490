// `twill list [CATEGORY]`: what is registered, per category, with each implementation's
// one-line description and option schema (name, type, default, constraint, doc).
// `twill list --names CATEGORY`: the registered names only, one per line in registration
// order (machine-readable, for scripts that run every registered implementation).
#include <fmt/format.h>

#include <algorithm>
#include <iostream>
#include <memory>

#include "app/commands.hpp"

namespace twill {
namespace {

void print_schema(std::ostream& out, const OptionSchema& schema, int indent) {
  std::size_t width = 0;
  for (const auto& spec : schema.options()) width = std::max(width, spec.name.size());
  for (const auto& spec : schema.options()) {
    std::string type = to_string(spec.type);
    if (spec.type == OptionType::Component || spec.type == OptionType::ComponentList)
      type += " (" + spec.category + ")";
    std::string details = type;
    if (spec.type != OptionType::Section && spec.type != OptionType::ComponentList)
      details += spec.is_required ? ", required" : ", default " + spec.default_text();
    const std::string constraint = spec.constraint_text();
    if (!constraint.empty()) details += ", " + constraint;
    out << fmt::format("{:{}}{:<{}}  {}  [{}]\n", "", indent, spec.name, width, spec.doc, details);
    if (spec.type == OptionType::Section) print_schema(out, *spec.section, indent + 2);
  }
}

void print_category(std::ostream& out, const Context& context, const std::string& name) {
  out << name << ":\n";
  const RegistryCategory* category = context.registry.find_category(name);
  if (!category || category->entries().empty()) {
    out << "  (none registered)\n";
    return;
  }
  for (const auto& entry : category->entries()) {
    out << "  " << entry.name << " — " << entry.description << "\n";
    if (entry.options.options().empty())
      out << "      (no options)\n";
    else
      print_schema(out, entry.options, 6);
  }
}

}  // namespace

void add_list_command(CLI::App& app, Context& context) {
  auto* cmd = app.add_subcommand("list", "List every registered implementation per category, with its options");
  auto category = std::make_shared<std::string>();
  auto names_only = std::make_shared<bool>(false);
  cmd->add_option("category", *category, "Only this category (discretization, optimizer, experiment, effect)");
  cmd->add_flag("--names", *names_only, "Print only the names of CATEGORY, one per line");
  cmd->callback([&context, category, names_only] {
    if (*names_only && category->empty())
      throw InputError({"command line", 0, "--names"}, "--names needs a CATEGORY");
    const auto names = context.registry.category_names();
    if (!category->empty()) {
      if (std::find(names.begin(), names.end(), *category) == names.end()) {
        std::string known;
        for (const auto& n : names) known += (known.empty() ? "" : ", ") + n;
        throw InputError({"command line", 0, "category"}, "unknown category '" + *category + "' (known: " + known + ")");
      }
      if (*names_only) {
        if (const RegistryCategory* found = context.registry.find_category(*category))
          for (const auto& entry : found->entries()) std::cout << entry.name << "\n";
      } else {
        print_category(std::cout, context, *category);
      }
      return;
    }
    for (std::size_t i = 0; i < names.size(); ++i) {
      if (i) std::cout << "\n";
      print_category(std::cout, context, names[i]);
    }
  });
}

}  // namespace twill
