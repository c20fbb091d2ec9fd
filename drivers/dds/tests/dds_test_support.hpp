// Shared by the test executable and the peer process: deterministic frames (so a receiver
// can check a frame arrived intact from its sequence alone), clocks and waiting.
#pragma once

#include <sys/types.h>

#include <chrono>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "fl/controller/monotonic_clock.hpp"
#include "fl/controller/process_image.hpp"

namespace fl::drivers::dds::test {

// The frame a camera sends with `sequence`: count = sequence % 9 (0..8, every fill level
// of the frame), every field a distinct function of camera, sequence and slot.
CameraFrame make_frame(CameraId camera, std::uint32_t sequence, std::int64_t frame_time_ns);
// True when `frame` is make_frame(camera, frame.sequence, frame.frame_time_ns).
bool frame_intact(CameraId camera, const CameraFrame& frame);

// CYCLONEDDS_URI of the shipped loopback configuration (config/dds).
std::string loopback_uri();

// Polls `done` every millisecond until it is true or `timeout` passed.
bool wait_until(const std::function<bool()>& done, std::chrono::milliseconds timeout,
                std::chrono::milliseconds poll = std::chrono::milliseconds(1));

// A child process running drivers_dds_peer with `args`, its stdout captured; killed
// (SIGKILL) and reaped on destruction if still running.
class PeerProcess {
 public:
  PeerProcess(const std::vector<std::string>& args, const std::string& cyclonedds_uri);
  // The same with another executable (the IDL-only peer of the interop tests).
  PeerProcess(const std::string& executable, const std::vector<std::string>& args,
              const std::string& cyclonedds_uri);
  ~PeerProcess();
  PeerProcess(const PeerProcess&) = delete;
  PeerProcess& operator=(const PeerProcess&) = delete;

  void kill_now();  // SIGKILL: no clean DDS shutdown, as a crashed camera node
  // Waits for exit; returns the exit status (or 128 + signal), -1 on timeout.
  int wait_exit(std::chrono::milliseconds timeout);
  // Everything the child wrote to stdout (call after wait_exit).
  std::string output();

 private:
  pid_t pid_ = -1;
  int stdout_fd_ = -1;
  int status_ = -1;
};

}  // namespace fl::drivers::dds::test
