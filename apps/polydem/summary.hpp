#pragma once
// --summary-json FILE: a machine-readable record of one run (issue 21). Every figure the printed report
// shows, at full precision (shortest decimal that reads back to the same double), plus the command line,
// the version, the settings of the subcommand and how the run ended (exit code and status).
//
// The report code of a subcommand calls summary().put("group.name", value) beside each figure it prints;
// main.cpp adds the option to the subcommands that support it, checks the path before the run and writes
// the file (atomically) after it, also when the run ends with exit code 3, 4 or 130. Keys are dotted
// paths, written as nested objects in the order they were first put. A value that does not exist (an
// undefined estimate, a non-finite number) is written as null with a "<name>_undefined" reason beside it.
#include <cstdint>
#include <string>
#include <string_view>
#include <type_traits>
#include <variant>
#include <vector>

namespace CLI {
class App;
}  // namespace CLI

namespace polydem::app {

class SummaryJson {
 public:
  using Value = std::variant<std::monostate, bool, std::int64_t, double, std::string, std::vector<double>,
                             std::vector<std::int64_t>>;

  /// Records `value` under the dotted `key` (a later put of the same key replaces it, in place).
  void put(std::string_view key, double value);
  void put(std::string_view key, std::int64_t value);
  void put(std::string_view key, int value) { put(key, static_cast<std::int64_t>(value)); }
  void put(std::string_view key, std::size_t value) { put(key, static_cast<std::int64_t>(value)); }
  void put(std::string_view key, bool value);
  void put(std::string_view key, std::string value);
  void put(std::string_view key, const char* value) { put(key, std::string(value)); }
  void put(std::string_view key, std::vector<double> values);
  void put(std::string_view key, std::vector<std::int64_t> values);
  /// `key` is null, and `key`_undefined holds why (e.g. "empty backbone").
  void undefined(std::string_view key, std::string reason);

  /// One cell of a table row: an integer, a number (full precision) or text.
  using Cell = std::variant<std::int64_t, double, std::string>;
  /// Appends a row to the table under the dotted key `table` (columns from the first call; a CSV header
  /// line "a,b,c" is accepted as is). Written as {"columns": [...], "rows": [[...], ...]}. No-op unless
  /// enabled(), so report loops pay nothing without --summary-json.
  void appendRow(std::string_view table, std::string_view columns, std::vector<Cell> row);

  /// True when a run asked for a summary (only then is put() worth its cost in a loop).
  bool enabled() const { return enabled_; }
  void enable() { enabled_ = true; }

  /// The JSON text: one object, nested by the dots of the keys, 2-space indented.
  std::string toJson() const;

 private:
  void set(std::string_view key, Value value);
  struct Table {
    std::vector<std::string> columns;
    std::vector<std::vector<Cell>> rows;
  };
  std::vector<std::pair<std::string, Value>> entries_;
  std::vector<std::pair<std::string, Table>> tables_;
  bool enabled_ = false;
};

/// A table cell from a number or text (integers stay integers; text: std::string, string_view, char*).
template <class T>
SummaryJson::Cell cell(const T& value) {
  if constexpr (std::is_same_v<T, bool>) {
    return std::int64_t{value ? 1 : 0};
  } else if constexpr (std::is_integral_v<T>) {
    return static_cast<std::int64_t>(value);
  } else if constexpr (std::is_floating_point_v<T>) {
    return static_cast<double>(value);
  } else {
    return std::string(value);
  }
}

/// `text` as a double-quoted string with \" \\ \n \t \r and \uXXXX escapes: a JSON string, and equally
/// a TOML basic string (the two formats share these escapes).
std::string quotedString(std::string_view text);

/// The summary of this process's run (one subcommand per process).
SummaryJson& summary();

/// Adds --summary-json to `cmd`; `path` receives the file name.
void addSummaryOption(CLI::App& cmd, std::string& path);

/// Command line, version, build flags and every option of `cmd` (given or default) into the summary.
void recordInvocation(int argc, const char* const* argv, const CLI::App& cmd);

/// How the run ended, into the summary: exit code, status word and, for errors, the message.
void recordExit(int exitCode, const std::string& message);

}  // namespace polydem::app
