// Running the package's programs and launch files from gtests, as a user runs them.
#pragma once

#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <string>

namespace novelty_detection {
namespace process_run {

struct ProcessRun {
  int code = 0;
  std::string out;  ///< stdout and stderr
};

/// Runs a shell command; its exit code (-1 when it did not exit) and its output.
inline ProcessRun run(const std::string& cmd) {
  ProcessRun r;
  FILE* p = ::popen((cmd + " 2>&1").c_str(), "r");
  if (!p) return {-1, "popen failed"};
  char buf[4096];
  while (std::fgets(buf, sizeof buf, p)) r.out += buf;
  const int status = ::pclose(p);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

/// The port of this process's own master (shifted by `port_shift`), so that tests running
/// at the same time do not share one.
inline std::string masterPort(int port_shift) {
  return std::to_string(20000 + (::getpid() + port_shift) % 20000);
}

/// `roslaunch novelty_detection FILE ARGS` on a master of its own (masterPort()).
inline std::string roslaunch(const std::string& file, const std::string& args, int port_shift,
                             int timeout_s) {
  const std::string port = masterPort(port_shift);
  return "ROS_MASTER_URI=http://localhost:" + port + " timeout " + std::to_string(timeout_s) +
         " roslaunch -p " + port + " novelty_detection " + file + " " + args;
}

}  // namespace process_run
}  // namespace novelty_detection
