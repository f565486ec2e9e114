#pragma once
// The verdict every jamming test gives (ideal contacts, load protocols, pressure leak).
#include <string_view>

namespace polydem::jamming {

/// Outcome of a jamming test. NotTested: the test did not run or cannot apply (no spheres, no LP solved,
/// nothing to watch), so it says nothing either way; never read it as "jammed".
enum class JammingVerdict { NotTested, Jammed, Unjammed, Undecided };

/// "not tested", "jammed", "unjammed", "undecided".
std::string_view verdictName(JammingVerdict verdict);

}  // namespace polydem::jamming
