#include "core/interrupt.hpp"

#include <csignal>

namespace polydem {

namespace {

volatile std::sig_atomic_t interruptFlag = 0;

extern "C" void onInterrupt(int signal) {
  if (interruptFlag != 0) {  // second signal: give up on the safe point
    std::signal(signal, SIG_DFL);
    std::raise(signal);
    return;
  }
  interruptFlag = signal;
}

}  // namespace

void installInterruptHandlers() {
  struct sigaction action {};
  action.sa_handler = &onInterrupt;
  sigemptyset(&action.sa_mask);
  action.sa_flags = 0;
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
}

bool interruptRequested() { return interruptFlag != 0; }
int interruptSignal() { return static_cast<int>(interruptFlag); }
void clearInterrupt() { interruptFlag = 0; }
void requestInterrupt(int signal) { interruptFlag = signal; }

}  // namespace polydem
