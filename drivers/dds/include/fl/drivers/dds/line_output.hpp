// The controller's outputs onto DDS: one LineCommand per scan and LineStatus on change and
// every status period. write() runs on the scan thread and only hands the output image to
// a publisher thread (triple buffer, then one non-blocking eventfd write to wake it): the
// serialisation and send inside dds_write allocate and lock, so they run there.
#pragma once

#include <atomic>
#include <cstdint>
#include <mutex>
#include <thread>

#include "fillet_line.h"
#include "fl/controller/cycle_stats.hpp"
#include "fl/controller/process_image.hpp"
#include "fl/drivers/dds/camera_input.hpp"
#include "fl/drivers/dds/entity.hpp"
#include "fl/drivers/dds/qos.hpp"
#include "fl/drivers/dds/triple_buffer.hpp"

namespace fl::drivers::dds {

struct LineOutputOptions {
  std::int64_t scan_period_ns = kScanPeriodNs;
  // LineStatus goes out on every change of state or faults, and at least this often so an
  // HMI sees the counters move: ten times a second.
  std::int64_t status_period_ns = 100'000'000;
};

// Latency of the frames the commands reacted to (write() with FrameStamps), on Cyclone's
// clock: a camera node on the same host shares it.
struct ReactionLatency {
  DistributionSummary transport;  // frame published -> taken by the controller's listener
  DistributionSummary reaction;   // frame published -> dds_write of the first command whose
                                  // scan read it returned
};

struct LineOutputCounters {
  std::uint64_t scans = 0;               // write() calls
  std::uint64_t commands_published = 0;  // dds_write succeeded
  std::uint64_t commands_dropped = 0;    // superseded before the publisher thread ran
  std::uint64_t write_failures = 0;      // dds_write returned an error
  std::uint64_t statuses_published = 0;
};

class DdsLineOutput {
 public:
  DdsLineOutput(const Participant& participant, LineOutputOptions options = {});
  ~DdsLineOutput();  // stops and joins the publisher thread
  DdsLineOutput(const DdsLineOutput&) = delete;
  DdsLineOutput& operator=(const DdsLineOutput&) = delete;

  // Scan thread, real-time. scan_time_ns: the scan's scheduled time (ProcessIo::read's now_ns).
  void write(std::int64_t scan_time_ns, const OutputImage& out) noexcept;
  // The same, for a scan that read the frames in `stamps` (fresh_mask): the publisher thread
  // measures their latency to this command's dds_write (reaction_latency()). A command
  // superseded before it was published takes its frames' measurement with it.
  void write(std::int64_t scan_time_ns, const OutputImage& out, const FrameStamps& stamps) noexcept;

  // Any thread: DDS-side facts the status carries (e.g. DdsCameraInput::stale_mask()).
  void set_camera_stale_mask(std::uint32_t mask) noexcept {
    camera_stale_mask_.store(mask, std::memory_order_relaxed);
  }
  void set_estimates_rejected(std::uint64_t count) noexcept {
    estimates_rejected_.store(count, std::memory_order_relaxed);
  }

  [[nodiscard]] LineOutputCounters counters() const noexcept;
  [[nodiscard]] ReactionLatency reaction_latency() const;
  [[nodiscard]] std::uint32_t command_readers() const { return command_writer_.matched_readers(); }

 private:
  struct Snapshot {
    std::int64_t time_ns = 0;
    std::uint64_t scan = 0;
    OutputImage out{};
    FrameStamps frames{};  // fresh_mask 0: no frame to measure
  };
  void publisher_main();
  void publish_status(const Snapshot& snapshot);
  void record_latency(const FrameStamps& frames);

  const LineOutputOptions options_;
  Topic command_topic_;
  Topic status_topic_;
  Writer command_writer_;
  Writer status_writer_;

  TripleBuffer<Snapshot> snapshots_;
  std::uint64_t scan_ = 0;  // scan thread's own
  int wake_fd_ = -1;        // eventfd: the scan thread's doorbell
  std::atomic<bool> stop_{false};

  std::atomic<std::uint64_t> scans_{0};
  std::atomic<std::uint64_t> commands_published_{0};
  std::atomic<std::uint64_t> commands_dropped_{0};
  std::atomic<std::uint64_t> write_failures_{0};
  std::atomic<std::uint64_t> statuses_published_{0};
  std::atomic<std::uint32_t> camera_stale_mask_{0};
  std::atomic<std::uint64_t> estimates_rejected_{0};

  // Publisher thread's own.
  std::uint64_t last_published_scan_ = 0;
  bool status_sent_ = false;
  LineState last_state_ = LineState::kStopped;
  std::uint32_t last_faults_ = 0;
  std::int64_t last_status_ns_ = 0;
  fl_LineCommand command_sample_{};
  fl_LineStatus status_sample_{};
  // 10 us bins to 200 ms: a reaction takes up to a scan period plus transport, and anything
  // beyond 200 ms lands in the overflow bin (reported as the maximum).
  mutable std::mutex latency_mutex_;  // publisher thread and readers; never the scan thread
  DurationHistogram transport_latency_{10'000, 200'000'000};
  DurationHistogram reaction_latency_{10'000, 200'000'000};

  std::thread thread_;  // last: starts when everything above exists
};

// The camera node's side (the twin's camera node, the test peer, the benchmark): publishes
// frames outside any real-time cycle.
class DdsCameraPublisher {
 public:
  DdsCameraPublisher(const Participant& participant,
                     std::int64_t camera_period_ns = kSlowestCameraPeriodNs,
                     const char* topic = kEstimatesTopic);
  // Throws DdsError when Cyclone refuses the sample.
  void publish(CameraId camera, const CameraFrame& frame);
  void publish(const fl_CameraEstimates& sample);  // raw, for tests of invalid samples
  [[nodiscard]] std::uint32_t matched_readers() const { return writer_.matched_readers(); }
  [[nodiscard]] dds_entity_t writer() const noexcept { return writer_.get(); }

 private:
  Topic topic_;
  Writer writer_;
  fl_CameraEstimates sample_{};
};

}  // namespace fl::drivers::dds
