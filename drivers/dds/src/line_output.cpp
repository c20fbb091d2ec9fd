#include "fl/drivers/dds/line_output.hpp"

#include <poll.h>
#include <spdlog/spdlog.h>
#include <sys/eventfd.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <ctime>

#include "fl/controller/monotonic_clock.hpp"
#include "fl/drivers/dds/convert.hpp"

namespace fl::drivers::dds {

DdsLineOutput::DdsLineOutput(const Participant& participant, LineOutputOptions options)
    : options_(options),
      command_topic_(participant, fl_LineCommand_desc, kCommandTopic),
      status_topic_(participant, fl_LineStatus_desc, kStatusTopic),
      command_writer_(participant, command_topic_, command_qos(options.scan_period_ns).get()),
      status_writer_(participant, status_topic_, status_qos().get()) {
  // Non-blocking: a doorbell the publisher has not answered yet just adds to the counter.
  wake_fd_ = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  if (wake_fd_ < 0) {
    throw DdsError(std::string("eventfd: ") + std::strerror(errno), DDS_RETCODE_ERROR);
  }
  thread_ = std::thread([this] { publisher_main(); });
}

DdsLineOutput::~DdsLineOutput() {
  stop_.store(true, std::memory_order_release);
  const std::uint64_t one = 1;
  (void)::write(wake_fd_, &one, sizeof one);
  if (thread_.joinable()) thread_.join();
  ::close(wake_fd_);
}

void DdsLineOutput::write(std::int64_t scan_time_ns, const OutputImage& out) noexcept {
  write(scan_time_ns, out, FrameStamps{});
}

void DdsLineOutput::write(std::int64_t scan_time_ns, const OutputImage& out,
                          const FrameStamps& stamps) noexcept {
  Snapshot& snapshot = snapshots_.back();
  snapshot.time_ns = scan_time_ns;
  snapshot.scan = ++scan_;
  snapshot.out = out;
  snapshot.frames = stamps;
  snapshots_.publish();
  scans_.store(scan_, std::memory_order_relaxed);
  // One system call that never blocks (EFD_NONBLOCK; the counter cannot overflow at one
  // increment per scan). A failure only delays the command to the next doorbell.
  const std::uint64_t one = 1;
  (void)::write(wake_fd_, &one, sizeof one);
}

LineOutputCounters DdsLineOutput::counters() const noexcept {
  LineOutputCounters counters;
  counters.scans = scans_.load(std::memory_order_relaxed);
  counters.commands_published = commands_published_.load(std::memory_order_relaxed);
  counters.commands_dropped = commands_dropped_.load(std::memory_order_relaxed);
  counters.write_failures = write_failures_.load(std::memory_order_relaxed);
  counters.statuses_published = statuses_published_.load(std::memory_order_relaxed);
  return counters;
}

void DdsLineOutput::publisher_main() {
  const int timeout_ms = static_cast<int>(options_.status_period_ns / 1'000'000);
  while (!stop_.load(std::memory_order_acquire)) {
    pollfd fd{wake_fd_, POLLIN, 0};
    const int ready = ::poll(&fd, 1, timeout_ms > 0 ? timeout_ms : 1);
    if (ready > 0) {
      std::uint64_t rings = 0;
      (void)::read(wake_fd_, &rings, sizeof rings);
    }
    if (stop_.load(std::memory_order_acquire)) break;
    if (snapshots_.update()) {
      const Snapshot& snapshot = snapshots_.front();
      if (snapshot.scan > last_published_scan_ + 1) {
        commands_dropped_.fetch_add(snapshot.scan - last_published_scan_ - 1,
                                    std::memory_order_relaxed);
      }
      last_published_scan_ = snapshot.scan;
      to_idl(snapshot.time_ns, snapshot.scan, snapshot.out, command_sample_);
      const dds_return_t result = command_writer_.write(command_sample_);
      if (result < 0) {
        const std::uint64_t failures = write_failures_.fetch_add(1, std::memory_order_relaxed) + 1;
        if ((failures & (failures - 1)) == 0) {
          spdlog::warn("dds: LineCommand write failed: {} ({} so far)", dds_strretcode(result),
                       failures);
        }
      } else {
        commands_published_.fetch_add(1, std::memory_order_relaxed);
        record_latency(snapshot.frames);
      }
    }
    if (last_published_scan_ > 0) publish_status(snapshots_.front());
  }
}

ReactionLatency DdsLineOutput::reaction_latency() const {
  const std::lock_guard lock(latency_mutex_);
  return {transport_latency_.summary(), reaction_latency_.summary()};
}

void DdsLineOutput::record_latency(const FrameStamps& frames) {
  if (frames.fresh_mask == 0) return;
  const std::int64_t now_ns = dds_time();
  const std::lock_guard lock(latency_mutex_);
  for (std::size_t c = 0; c < kCameraCount; ++c) {
    if ((frames.fresh_mask & (1U << c)) == 0 || frames.source_ns[c] <= 0) continue;
    transport_latency_.record(frames.arrival_ns[c] - frames.source_ns[c]);
    reaction_latency_.record(now_ns - frames.source_ns[c]);
  }
}

void DdsLineOutput::publish_status(const Snapshot& snapshot) {
  const std::int64_t now_ns = monotonic_now_ns();
  const bool changed = !status_sent_ || snapshot.out.state != last_state_ ||
                       snapshot.out.active_faults != last_faults_;
  if (!changed && now_ns - last_status_ns_ < options_.status_period_ns) return;
  std::memset(&status_sample_, 0, sizeof status_sample_);
  status_sample_.time_ns = snapshot.time_ns;
  status_sample_.state = to_idl(snapshot.out.state);
  status_sample_.active_faults = snapshot.out.active_faults;
  status_sample_.scans = snapshot.scan;
  status_sample_.commands_published = commands_published_.load(std::memory_order_relaxed);
  status_sample_.commands_dropped = commands_dropped_.load(std::memory_order_relaxed);
  status_sample_.camera_stale_mask = camera_stale_mask_.load(std::memory_order_relaxed);
  status_sample_.estimates_rejected_transport = estimates_rejected_.load(std::memory_order_relaxed);
  if (status_writer_.write(status_sample_) >= 0) {
    statuses_published_.fetch_add(1, std::memory_order_relaxed);
  }
  status_sent_ = true;
  last_state_ = snapshot.out.state;
  last_faults_ = snapshot.out.active_faults;
  last_status_ns_ = now_ns;
}

DdsCameraPublisher::DdsCameraPublisher(const Participant& participant,
                                       std::int64_t camera_period_ns, const char* topic)
    : topic_(participant, fl_CameraEstimates_desc, topic),
      writer_(participant, topic_, estimates_qos(camera_period_ns).get()) {}

void DdsCameraPublisher::publish(CameraId camera, const CameraFrame& frame) {
  to_idl(camera, frame, sample_);
  check(writer_.write(sample_), "dds_write CameraEstimates");
}

void DdsCameraPublisher::publish(const fl_CameraEstimates& sample) {
  check(writer_.write(sample), "dds_write CameraEstimates");
}

}  // namespace fl::drivers::dds
