// libFuzzer target: the TOML scene reader of `polydem relax` (app::parseRelaxScene) on arbitrary text.
// Property: only ConfigError or InputError escape it (a crash, a hang, another exception or a sanitizer
// report is a finding). The reader belongs to apps/polydem/relax_scene.cpp; this target only calls it.
#include <cstdint>
#include <string>

#include "apps/polydem/relax_scene.hpp"
#include "core/errors.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    polydem::app::parseRelaxScene(text, {}, "fuzz.toml");
  } catch (const polydem::ConfigError&) {
  } catch (const polydem::InputError&) {
  }
  return 0;
}
