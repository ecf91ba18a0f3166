// The exit-code convention shared by the command-line tools: 2 with one line on stderr when
// the arguments are bad, 1 when the run fails (unreadable or invalid input), else run's code.
#pragma once

#include <exception>
#include <iostream>
#include <string>

#include "novelty_detection/error_text.h"
#include "novelty_detection/process_memory.h"

namespace novelty_detection {

/// parse(argc, argv) returns the tool's options; run(options) returns its exit code. Errors
/// print as "NAME: message" (plus `usage_hint` after a bad argument). Freed buffers stay in
/// the process's heap (process_memory.h).
template <class Parse, class Run>
int runTool(const char* name, const std::string& usage_hint, int argc, char** argv, Parse parse,
            Run run) {
  keepFreedBuffers();
  decltype(parse(argc, argv)) options;
  try {
    options = parse(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << name << ": " << e.what() << usage_hint << "\n";
    return 2;
  }
  try {
    return run(options);
  } catch (const std::exception& e) {
    std::cerr << name << ": " << errorText(e) << "\n";
    return 1;
  }
}

}  // namespace novelty_detection
