#pragma once
// Interrupts (SIGINT, SIGTERM) as a flag that long runs poll at safe points: the run then writes its
// checkpoint and output and ends with a documented exit code instead of dying mid-write.
//
// installInterruptHandlers() replaces the default action of SIGINT and SIGTERM by setting the flag; a
// second signal of the same kind while the flag is set restores the default action and re-raises, so a
// run that does not reach a safe point can still be killed with a second Ctrl-C.
namespace polydem {

/// Install the handlers (idempotent).
void installInterruptHandlers();
/// True once SIGINT or SIGTERM arrived (after installInterruptHandlers()).
bool interruptRequested();
/// The signal number that set the flag (0 if none).
int interruptSignal();
/// Clear the flag (tests).
void clearInterrupt();
/// Set the flag as if `signal` had arrived (tests, and the Python module's KeyboardInterrupt).
void requestInterrupt(int signal);

}  // namespace polydem
