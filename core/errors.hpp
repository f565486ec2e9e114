#pragma once
// Errors: loud at the boundary (configuration, input files), silent and fast inside kernels.
#include <stdexcept>
#include <string>

namespace polydem {

/// A scene, command line or API argument is invalid. The message names the key, the value and what
/// was expected.
class ConfigError : public std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// A file could not be read or is malformed. The message names the file, the line and the problem.
class InputError : public std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// A run became unstable or unphysical (NaN, excessive overlap, energy growth, particle lost).
/// The message names the step, the particles and the likely cause.
class SimulationError : public std::runtime_error {
  using std::runtime_error::runtime_error;
};

[[noreturn]] void assertionFailed(const char* condition, const char* message, const char* file, int line);

}  // namespace polydem

#if defined(POLYDEM_ENABLE_ASSERTS) && POLYDEM_ENABLE_ASSERTS
#define POLYDEM_ASSERT(cond, message)                                            \
  do {                                                                           \
    if (!(cond)) ::polydem::assertionFailed(#cond, message, __FILE__, __LINE__); \
  } while (false)
#else
#define POLYDEM_ASSERT(cond, message) \
  do {                                \
  } while (false)
#endif
