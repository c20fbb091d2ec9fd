#include "dds_test_support.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <thread>

#include "fl/controller/monotonic_clock.hpp"

namespace fl::drivers::dds::test {

CameraFrame make_frame(CameraId camera, std::uint32_t sequence, std::int64_t frame_time_ns) {
  CameraFrame frame;
  frame.frame_time_ns = frame_time_ns;
  frame.sequence = sequence;
  frame.count = static_cast<std::uint8_t>(sequence % (kMaxEstimatesPerFrame + 1));
  const auto c = static_cast<float>(index(camera));
  for (std::size_t i = 0; i < frame.count; ++i) {
    const auto slot = static_cast<float>(i);
    const auto seq = static_cast<float>(sequence % 1000);  // exact in a float
    FilletEstimate& e = frame.estimates[i];
    e.x_mm = -150.0F + seq * 0.25F + slot;  // within a 300 mm field of view
    e.y_mm = 10.0F * c - slot;
    e.angle_rad = -3.0F + 0.75F * slot;  // -3 .. 2.25 rad
    e.confidence = 0.125F * slot;        // 0 .. 0.875
    e.hand = static_cast<Hand>((sequence + i) % 3);
    e.side = static_cast<SideUp>((sequence + 2 * i) % 3);
    e.singulated = ((sequence + i) % 2) == 0;
  }
  return frame;
}

bool frame_intact(CameraId camera, const CameraFrame& frame) {
  const CameraFrame expected = make_frame(camera, frame.sequence, frame.frame_time_ns);
  if (frame.count != expected.count) return false;
  for (std::size_t i = 0; i < kMaxEstimatesPerFrame; ++i) {
    const FilletEstimate& a = frame.estimates[i];
    const FilletEstimate& b = expected.estimates[i];
    if (a.x_mm != b.x_mm || a.y_mm != b.y_mm || a.angle_rad != b.angle_rad ||
        a.confidence != b.confidence || a.hand != b.hand || a.side != b.side ||
        a.singulated != b.singulated) {
      return false;
    }
  }
  return true;
}

bool wait_until(const std::function<bool()>& done, std::chrono::milliseconds timeout,
                std::chrono::milliseconds poll) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (!done()) {
    if (std::chrono::steady_clock::now() > end) return false;
    std::this_thread::sleep_for(poll);
  }
  return true;
}

std::string loopback_uri() {
  return std::string("file://") + FL_DDS_CONFIG_DIR + "/cyclonedds-loopback.xml";
}

PeerProcess::PeerProcess(const std::vector<std::string>& args, const std::string& cyclonedds_uri)
    : PeerProcess(FL_DDS_PEER, args, cyclonedds_uri) {}

PeerProcess::PeerProcess(const std::string& executable, const std::vector<std::string>& args,
                         const std::string& cyclonedds_uri) {
  int pipe_fds[2] = {-1, -1};
  if (pipe(pipe_fds) != 0) std::abort();
  std::vector<std::string> argv_strings{executable};
  argv_strings.insert(argv_strings.end(), args.begin(), args.end());
  std::vector<char*> argv;
  argv.reserve(argv_strings.size() + 1);
  for (auto& s : argv_strings) argv.push_back(s.data());
  argv.push_back(nullptr);
  pid_ = fork();
  if (pid_ == 0) {
    dup2(pipe_fds[1], STDOUT_FILENO);
    close(pipe_fds[0]);
    close(pipe_fds[1]);
    setenv("CYCLONEDDS_URI", cyclonedds_uri.c_str(), 1);
    execv(argv[0], argv.data());
    _exit(127);
  }
  close(pipe_fds[1]);
  stdout_fd_ = pipe_fds[0];
}

PeerProcess::~PeerProcess() {
  if (pid_ > 0 && status_ < 0) {
    kill(pid_, SIGKILL);
    waitpid(pid_, nullptr, 0);
  }
  if (stdout_fd_ >= 0) close(stdout_fd_);
}

void PeerProcess::kill_now() {
  if (pid_ > 0 && status_ < 0) kill(pid_, SIGKILL);
}

int PeerProcess::wait_exit(std::chrono::milliseconds timeout) {
  if (status_ >= 0) return status_;
  const auto end = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    int raw = 0;
    const pid_t done = waitpid(pid_, &raw, WNOHANG);
    if (done == pid_) {
      status_ = WIFEXITED(raw) ? WEXITSTATUS(raw) : 128 + WTERMSIG(raw);
      return status_;
    }
    if (std::chrono::steady_clock::now() > end) return -1;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
}

std::string PeerProcess::output() {
  std::string text;
  char buffer[512];
  const int flags = fcntl(stdout_fd_, F_GETFL);
  fcntl(stdout_fd_, F_SETFL, flags | O_NONBLOCK);
  for (;;) {
    const ssize_t n = ::read(stdout_fd_, buffer, sizeof buffer);
    if (n <= 0) break;
    text.append(buffer, static_cast<std::size_t>(n));
  }
  return text;
}

}  // namespace fl::drivers::dds::test
