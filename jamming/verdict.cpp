#include "jamming/verdict.hpp"

namespace polydem::jamming {

std::string_view verdictName(JammingVerdict verdict) {
  switch (verdict) {
    case JammingVerdict::Jammed:
      return "jammed";
    case JammingVerdict::Unjammed:
      return "unjammed";
    case JammingVerdict::Undecided:
      return "undecided";
    case JammingVerdict::NotTested:
      break;
  }
  return "not tested";
}

}  // namespace polydem::jamming
