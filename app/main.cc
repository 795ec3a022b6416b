#include "app/command.h"

// The stop signals' handlers before any other code of the program runs (the static
// initialisers of its own sources included): a signal in a command's first milliseconds ends
// it with exit 130 and its message too, not with the default 143.
__attribute__((constructor(101))) static void StopSignalsFirst() {
  armsig::app::InstallStopSignals();
}

int main(int argc, char** argv) { return armsig::app::Main(argc, argv); }
