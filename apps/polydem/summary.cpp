#include "apps/polydem/summary.hpp"

#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <ctime>
#include <map>
#include <memory>

#include "apps/polydem/exit_codes.hpp"
#include "polydem/config.hpp"

namespace polydem::app {

std::string quotedString(std::string_view text) {
  std::string out = "\"";
  for (const char c : text) {
    switch (c) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\t':
        out += "\\t";
        break;
      case '\r':
        out += "\\r";
        break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          out += fmt::format("\\u{:04x}", static_cast<unsigned>(c));
        } else {
          out += c;
        }
    }
  }
  return out + "\"";
}

namespace {

// fmt's "{}" is the shortest decimal that reads back to the same double; JSON has no NaN or infinity
// (put() turns those into null with a reason before they get here).
std::string number(double v) { return std::isfinite(v) ? fmt::format("{}", v) : "null"; }

struct ValueText {
  std::string operator()(std::monostate) const { return "null"; }
  std::string operator()(bool b) const { return b ? "true" : "false"; }
  std::string operator()(std::int64_t i) const { return fmt::format("{}", i); }
  std::string operator()(double d) const { return number(d); }
  std::string operator()(const std::string& s) const { return quotedString(s); }
  std::string operator()(const std::vector<double>& v) const {
    std::string out = "[";
    for (std::size_t k = 0; k < v.size(); ++k) out += (k ? ", " : "") + number(v[k]);
    return out + "]";
  }
  std::string operator()(const std::vector<std::int64_t>& v) const {
    std::string out = "[";
    for (std::size_t k = 0; k < v.size(); ++k) out += fmt::format("{}{}", k ? ", " : "", v[k]);
    return out + "]";
  }
};

std::string cellText(const SummaryJson::Cell& cell) {
  if (const auto* i = std::get_if<std::int64_t>(&cell)) return fmt::format("{}", *i);
  if (const auto* d = std::get_if<double>(&cell)) return number(*d);
  return quotedString(std::get<std::string>(cell));
}

// The dotted keys as a tree, children in first-put order; a node holds a value, a table or children.
struct Node {
  std::string name;
  const SummaryJson::Value* value = nullptr;
  std::string tableText;
  std::vector<std::unique_ptr<Node>> children;

  Node& child(std::string_view childName) {
    for (auto& c : children) {
      if (c->name == childName) return *c;
    }
    children.push_back(std::make_unique<Node>());
    children.back()->name = std::string(childName);
    return *children.back();
  }
};

void writeNode(const Node& node, int depth, std::string& out) {
  const std::string indent(static_cast<std::size_t>(2 * (depth + 1)), ' ');
  out += "{\n";
  for (std::size_t k = 0; k < node.children.size(); ++k) {
    const Node& c = *node.children[k];
    out += indent + quotedString(c.name) + ": ";
    if (!c.children.empty()) {
      writeNode(c, depth + 1, out);  // a key that is also a group keeps the group (put() prevents both)
    } else if (!c.tableText.empty()) {
      out += c.tableText;
    } else if (c.value != nullptr) {
      out += std::visit(ValueText{}, *c.value);
    } else {
      out += "null";
    }
    out += k + 1 < node.children.size() ? ",\n" : "\n";
  }
  out += std::string(static_cast<std::size_t>(2 * depth), ' ') + "}";
}

std::string statusWord(int exitCode) {
  switch (exitCode) {
    case kExitOk:
      return "ok";
    case kExitConfigError:
      return "configuration or input error";
    case kExitSimulationError:
      return "simulation error";
    case kExitTargetNotReached:
      return "target not reached";
    case kExitInterrupted:
      return "interrupted";
    default:
      return "error";
  }
}

}  // namespace

void SummaryJson::set(std::string_view key, Value value) {
  for (auto& [k, v] : entries_) {
    if (k == key) {
      v = std::move(value);
      return;
    }
  }
  entries_.emplace_back(std::string(key), std::move(value));
}

void SummaryJson::put(std::string_view key, double value) {
  if (std::isfinite(value)) {
    set(key, value);
  } else {
    undefined(key, fmt::format("not a finite number ({})", value));
  }
}
void SummaryJson::put(std::string_view key, std::int64_t value) { set(key, value); }
void SummaryJson::put(std::string_view key, bool value) { set(key, value); }
void SummaryJson::put(std::string_view key, std::string value) { set(key, std::move(value)); }
void SummaryJson::put(std::string_view key, std::vector<double> values) {
  if (std::all_of(values.begin(), values.end(), [](double v) { return std::isfinite(v); })) {
    set(key, std::move(values));
  } else {
    undefined(key, "contains a non-finite number");
  }
}
void SummaryJson::put(std::string_view key, std::vector<std::int64_t> values) { set(key, std::move(values)); }

void SummaryJson::undefined(std::string_view key, std::string reason) {
  set(key, std::monostate{});
  set(std::string(key) + "_undefined", std::move(reason));
}

void SummaryJson::appendRow(std::string_view table, std::string_view columns, std::vector<Cell> row) {
  if (!enabled_) return;
  for (auto& [name, t] : tables_) {
    if (name == table) {
      t.rows.push_back(std::move(row));
      return;
    }
  }
  Table t;
  std::string_view rest = columns;
  while (!rest.empty() && (rest.back() == '\n' || rest.back() == ' ')) rest.remove_suffix(1);
  while (!rest.empty()) {
    const std::size_t comma = rest.find(',');
    t.columns.emplace_back(rest.substr(0, comma));
    if (comma == std::string_view::npos) break;
    rest.remove_prefix(comma + 1);
  }
  t.rows.push_back(std::move(row));
  tables_.emplace_back(std::string(table), std::move(t));
}

namespace {
Node& nodeAt(Node& root, const std::string& key) {
  Node* node = &root;
  std::size_t start = 0;
  while (true) {
    const std::size_t dot = key.find('.', start);
    node = &node->child(std::string_view(key).substr(start, dot == std::string::npos ? dot : dot - start));
    if (dot == std::string::npos) return *node;
    start = dot + 1;
  }
}
}  // namespace

std::string SummaryJson::toJson() const {
  Node root;
  for (const auto& [key, value] : entries_) nodeAt(root, key).value = &value;
  for (const auto& [key, table] : tables_) {
    std::string text = "{\"columns\": [";
    for (std::size_t k = 0; k < table.columns.size(); ++k) text += (k ? ", " : "") + quotedString(table.columns[k]);
    text += "], \"rows\": [";
    for (std::size_t r = 0; r < table.rows.size(); ++r) {
      text += r ? ",\n    [" : "\n    [";
      for (std::size_t k = 0; k < table.rows[r].size(); ++k) text += (k ? ", " : "") + cellText(table.rows[r][k]);
      text += "]";
    }
    nodeAt(root, key).tableText = text + "]}";
  }
  std::string out;
  writeNode(root, 0, out);
  return out + "\n";
}

SummaryJson& summary() {
  static SummaryJson instance;
  return instance;
}

void addSummaryOption(CLI::App& cmd, std::string& path) {
  cmd.add_option("--summary-json", path,
                 "write a JSON summary of the run: every reported figure at full precision, the command, "
                 "version and settings, and how the run ended (written also when it ends early)");
}

void recordInvocation(int argc, const char* const* argv, const CLI::App& cmd) {
  SummaryJson& s = summary();
  std::vector<std::string> args(argv, argv + argc);
  std::string line;
  for (const std::string& a : args) line += (line.empty() ? "" : " ") + a;
  s.put("polydem.version", POLYDEM_VERSION);
  s.put("polydem.build_flags", POLYDEM_CXX_FLAGS);
  s.put("command.line", line);
  s.put("command.subcommand", cmd.get_name());
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&now, &utc);
  char stamp[32];
  std::strftime(stamp, sizeof stamp, "%Y-%m-%dT%H:%M:%SZ", &utc);
  s.put("command.started_utc", std::string(stamp));
  for (const CLI::Option* opt : cmd.get_options()) {
    std::string name = opt->get_single_name();
    if (name.empty() || name == "help" || name == "summary-json") continue;
    std::string value;
    if (opt->count() > 0) {
      for (const std::string& r : opt->results()) value += (value.empty() ? "" : ",") + r;
    } else {
      value = opt->get_default_str();
    }
    std::replace(name.begin(), name.end(), '.', '_');  // dots would nest
    s.put("settings." + name, value);
  }
}

void recordExit(int exitCode, const std::string& message) {
  SummaryJson& s = summary();
  s.put("exit.code", exitCode);
  s.put("exit.status", statusWord(exitCode));
  if (!message.empty()) s.put("exit.message", message);
}

}  // namespace polydem::app
