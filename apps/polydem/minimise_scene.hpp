// Scene files of `polydem minimise` (TOML): one table, [minimise], whose keys are the command's long options
// with '_' for '-' (target_pressure = 1e-6 is --target-pressure 1e-6). A key takes effect only where the
// option is not on the command line, so command-line options override the scene; every value goes through
// the option's own check, and an error names the file, the line and the key. examples/minimise_uv10.toml
// lists every key.
#pragma once

#include <filesystem>
#include <set>
#include <string>

namespace CLI {
class App;
}  // namespace CLI

namespace polydem::app {

/// Sets the options of `cmd` that the command line left unset from `file`'s [minimise] table. String
/// values of the keys in `pathKeys` that are relative paths are taken relative to the scene's directory.
/// Throws InputError for a file that cannot be read or parsed, ConfigError for an unknown section or key,
/// a value of the wrong type or one the option rejects.
void applyMinimiseScene(const std::filesystem::path& file, CLI::App& cmd, const std::set<std::string>& pathKeys);

}  // namespace polydem::app
