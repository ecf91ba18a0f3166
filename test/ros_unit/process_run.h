// Running the package's programs and launch files from gtests, as a user runs them.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <map>
#include <mutex>
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

/// Whether a TCP server could listen on `port` now (as a master does: any address, the
/// address reusable).
inline bool portFree(int port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return false;
  const int one = 1;
  ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_ANY);
  addr.sin_port = htons(static_cast<std::uint16_t>(port));
  const bool ok = ::bind(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) == 0;
  ::close(fd);
  return ok;
}

/// The port of a master of this process's own, one for each `port_shift` (the same on every
/// call): a free one below the system's ephemeral range, where rostest's masters and every
/// node's servers take theirs (a test sharing a master with another's nodes sees their
/// topics), starting from one drawn from the process id so that tests running at the same
/// time start apart.
inline std::string masterPort(int port_shift) {
  static std::mutex mutex;
  static std::map<int, int> ports;  // port_shift: port
  std::lock_guard<std::mutex> lock(mutex);
  const auto known = ports.find(port_shift);
  if (known != ports.end()) return std::to_string(known->second);
  int ephemeral = 32768;
  std::ifstream("/proc/sys/net/ipv4/ip_local_port_range") >> ephemeral;
  const int lo = 20000, hi = std::max(lo + 2000, ephemeral) - 1, span = hi - lo + 1;
  const int start =
      static_cast<int>((static_cast<long>(::getpid()) * 61 + port_shift * 997) % span);
  for (int k = 0; k < span; ++k) {
    const int port = lo + (start + k) % span;
    bool taken = false;
    for (const auto& entry : ports) taken = taken || entry.second == port;
    if (!taken && portFree(port)) {
      ports[port_shift] = port;
      return std::to_string(port);
    }
  }
  return std::to_string(lo + start);  // none free: the master's start fails and says so
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
