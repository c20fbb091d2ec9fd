// candump (can-utils) as an independent peer on vcan0 inside the qemu guest: the guest's
// init copies it to /opt/candump (drivers/tests/run_vcan_tests.sh). It records every frame
// on the bus in its log format ("(stamp) vcan0 080#") while a test runs.
#pragma once

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstddef>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

extern char** environ;

namespace fl::drivers::test {

inline constexpr const char* kCandump = "/opt/candump";

// Starts candump on vcan0 when it is in the guest; running() says whether it is. `interface`
// is candump's interface argument with its optional filters ("vcan0,080:7FF"): the kernel
// then hands candump only those frames, which keeps it light on the guest's one emulated CPU.
class Candump {
 public:
  explicit Candump(std::string log_path = "/tmp/candump.log", std::string interface = "vcan0")
      : log_path_(std::move(log_path)), interface_(std::move(interface)) {
    if (access(kCandump, X_OK) != 0) {
      return;
    }
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log_path_.c_str(),
                                     O_WRONLY | O_CREAT | O_TRUNC, 0644);
    char arg0[] = "candump";
    char arg1[] = "-L";
    char* argv[] = {arg0, arg1, interface_.data(), nullptr};
    if (posix_spawn(&pid_, kCandump, &actions, nullptr, argv, environ) != 0) {
      pid_ = -1;
    }
    posix_spawn_file_actions_destroy(&actions);
    usleep(200'000);  // candump binds its socket before the test sends
  }
  [[nodiscard]] bool running() const { return pid_ > 0; }
  // Stops candump and returns its log lines ("(stamp) vcan0 080#").
  std::vector<std::string> finish() {
    std::vector<std::string> lines;
    if (pid_ <= 0) {
      return lines;
    }
    usleep(100'000);
    kill(pid_, SIGINT);
    int status = 0;
    waitpid(pid_, &status, 0);
    pid_ = -1;
    std::ifstream log(log_path_);
    for (std::string line; std::getline(log, line);) {
      lines.push_back(line);
    }
    return lines;
  }
  ~Candump() { finish(); }

 private:
  std::string log_path_;
  std::string interface_;
  pid_t pid_ = -1;
};

// Log lines that contain `needle`, e.g. " 080#" for the SYNCs.
inline std::size_t count_frames(const std::vector<std::string>& lines, const std::string& needle) {
  return static_cast<std::size_t>(std::count_if(
      lines.begin(), lines.end(),
      [&](const std::string& line) { return line.find(needle) != std::string::npos; }));
}

}  // namespace fl::drivers::test
