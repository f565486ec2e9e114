#include "apps/polydem/minimise_scene.hpp"

#include <fmt/format.h>
#include <toml++/toml.h>

#include <CLI/CLI.hpp>
#include <fstream>
#include <optional>
#include <sstream>
#include <vector>

#include "core/errors.hpp"

namespace polydem::app {

namespace {

std::string lineOf(const toml::node& n) { return fmt::format("line {}", n.source().begin.line); }

/// The value as the command line would spell it; empty optional for arrays, tables and dates.
std::optional<std::string> asArgument(const toml::node& n) {
  if (const auto* s = n.as_string()) return s->get();
  if (const auto* i = n.as_integer()) return std::to_string(i->get());
  if (const auto* f = n.as_floating_point()) return fmt::format("{}", f->get());  // shortest round trip
  if (const auto* b = n.as_boolean()) return std::string(b->get() ? "true" : "false");
  return std::nullopt;
}

std::string validKeys(const CLI::App& cmd) {
  std::string out;
  for (const CLI::Option* o : cmd.get_options()) {
    if (o->get_lnames().empty() || o->get_lnames().front() == "help") continue;
    std::string name = o->get_lnames().front();
    for (char& c : name) c = c == '-' ? '_' : c;
    out += (out.empty() ? "" : ", ") + name;
  }
  return out;
}

}  // namespace

void applyMinimiseScene(const std::filesystem::path& file, CLI::App& cmd, const std::set<std::string>& pathKeys) {
  std::ifstream in(file);
  if (!in) throw InputError(fmt::format("{}: cannot open scene file", file.string()));
  std::stringstream text;
  text << in.rdbuf();
  toml::table root;
  try {
    root = toml::parse(text.str(), file.string());
  } catch (const toml::parse_error& e) {
    throw InputError(
        fmt::format("{}:{}:{}: {}", file.string(), e.source().begin.line, e.source().begin.column, e.description()));
  }
  for (const auto& [key, node] : root) {
    if (key.str() != "minimise") {
      throw ConfigError(fmt::format("{}: {}: unknown {} '{}' (a minimise scene holds one table, [minimise])",
                                    file.string(), lineOf(node), node.is_table() ? "section" : "key", key.str()));
    }
  }
  const toml::node* section = root.get("minimise");
  if (section == nullptr) throw ConfigError(fmt::format("{}: no [minimise] table", file.string()));
  const toml::table* table = section->as_table();
  if (table == nullptr) {
    throw ConfigError(fmt::format("{}: {}: minimise must be a table ([minimise])", file.string(), lineOf(*section)));
  }
  for (const auto& [key, node] : *table) {
    const std::string name(key.str());
    std::string flag = "--" + name;
    for (char& c : flag) c = c == '_' ? '-' : c;
    CLI::Option* option = name.find('-') == std::string::npos ? cmd.get_option_no_throw(flag) : nullptr;
    if (option == nullptr || option->get_lnames().empty() || name == "help") {
      throw ConfigError(fmt::format("{}: {}: unknown key minimise.{} (valid: {})", file.string(), lineOf(node), name,
                                    validKeys(cmd)));
    }
    std::optional<std::string> value = asArgument(node);
    if (!value) {
      throw ConfigError(
          fmt::format("{}: {}: minimise.{} must be a number or a string", file.string(), lineOf(node), name));
    }
    if (option->count() > 0) continue;  // the command line wins
    if (pathKeys.count(name) && !value->empty() && std::filesystem::path(*value).is_relative()) {
      *value = (file.parent_path() / *value).string();
    }
    try {
      option->add_result(*value);
      option->run_callback();
    } catch (const CLI::Error& e) {
      throw ConfigError(
          fmt::format("{}: {}: minimise.{} = {}: {}", file.string(), lineOf(node), name, *value, e.what()));
    }
  }
}

}  // namespace polydem::app
