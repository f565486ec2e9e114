#pragma once
// Exit codes of the polydem program (documented in README.md, "Exit codes"). 0 only when the requested
// target was reached; a run that ends early still writes its output, marked "target not reached" with
// the reason, before it returns one of the non-zero codes below.
namespace polydem::app {

enum ExitCode : int {
  kExitOk = 0,                ///< the requested target was reached / the command did what was asked
  kExitError = 1,             ///< unexpected error (a bug: please report it)
  kExitConfigError = 2,       ///< bad command line, scene key or input file; nothing was computed
  kExitSimulationError = 3,   ///< the run became unstable or unphysical (the message names the cause)
  kExitTargetNotReached = 4,  ///< budget exhausted or jammed before the target; output written and marked
  kExitInterrupted = 130,     ///< SIGINT/SIGTERM: checkpoint (if configured) and output written, then stopped
};

}  // namespace polydem::app
