// The line's I/O over DDS besides cameras and the controller's commands: the sensor part of
// the input image (fl/line/sensors, LineSensors) and the drives' feedback (fl/drive/feedback),
// and the commands as the drives' side receives them. Two sides:
//   - controller: DdsSensorInput, read on the scan thread like DdsCameraInput (listeners take
//     and convert, triple buffers hand over, read() only copies);
//   - line I/O (the twin in two-process mode, a gateway on a real line): DdsSensorPublisher
//     and DdsCommandInput, used outside any hard real-time cycle.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <mutex>

#include "fillet_line.h"
#include "fl/controller/cycle_stats.hpp"
#include "fl/controller/process_image.hpp"
#include "fl/drivers/dds/entity.hpp"
#include "fl/drivers/dds/qos.hpp"
#include "fl/drivers/dds/triple_buffer.hpp"

namespace fl::drivers::dds {

struct SensorInputCounters {
  std::uint64_t sensors_accepted = 0;
  std::uint64_t sensors_rejected = 0;  // an analogue value not finite
  std::uint64_t feedback_accepted = 0;
  std::uint64_t feedback_rejected = 0;  // drive id out of range
};

// Controller side: the newest LineSensors and each drive's newest DriveFeedback.
class DdsSensorInput {
 public:
  explicit DdsSensorInput(const Participant& participant,
                          std::int64_t scan_period_ns = kScanPeriodNs);
  ~DdsSensorInput();  // deletes the readers first, so no listener runs on a dead object
  DdsSensorInput(const DdsSensorInput&) = delete;
  DdsSensorInput& operator=(const DdsSensorInput&) = delete;

  // Scan thread, real-time: copies the sensor members and in.drives; time and cameras stay.
  void read(InputImage& in) noexcept;

  // Any thread. CLOCK_MONOTONIC of the newest sensors sample's arrival; 0: none yet.
  [[nodiscard]] std::int64_t last_sensors_arrival_ns() const noexcept {
    return last_sensors_arrival_ns_.load(std::memory_order_acquire);
  }
  [[nodiscard]] bool delivered() const noexcept { return last_sensors_arrival_ns() != 0; }
  [[nodiscard]] SensorInputCounters counters() const noexcept;
  [[nodiscard]] std::uint32_t matched_writers() const { return sensors_reader_.matched_writers(); }

 private:
  static void on_sensors(dds_entity_t reader, void* arg);
  static void on_feedback(dds_entity_t reader, void* arg);

  TripleBuffer<fl_LineSensors> sensors_;
  std::array<TripleBuffer<DriveFeedback>, kDriveCount> drives_{};
  std::atomic<std::int64_t> last_sensors_arrival_ns_{0};
  std::atomic<std::uint64_t> sensors_accepted_{0};
  std::atomic<std::uint64_t> sensors_rejected_{0};
  std::atomic<std::uint64_t> feedback_accepted_{0};
  std::atomic<std::uint64_t> feedback_rejected_{0};
  // Listener side, one mutex per reader: one producer per triple buffer.
  std::mutex sensors_mutex_;
  std::mutex feedback_mutex_;
  fl_LineSensors sensors_sample_{};
  std::array<fl_DriveFeedback, kDriveCount> feedback_samples_{};

  Topic sensors_topic_;
  Topic feedback_topic_;
  Reader sensors_reader_;  // last: created when everything above exists, deleted first
  Reader feedback_reader_;
};

// Line I/O side: publishes the sensor part and the drives' feedback of an input image.
class DdsSensorPublisher {
 public:
  explicit DdsSensorPublisher(const Participant& participant,
                              std::int64_t scan_period_ns = kScanPeriodNs);
  // Writes one LineSensors and one DriveFeedback per drive; returns false when Cyclone
  // refused any of them (counted in write_failures()).
  bool publish(std::uint64_t scan, const InputImage& in);
  [[nodiscard]] std::uint64_t write_failures() const noexcept { return write_failures_; }
  [[nodiscard]] std::uint32_t matched_readers() const { return sensors_writer_.matched_readers(); }

 private:
  Topic sensors_topic_;
  Topic feedback_topic_;
  Writer sensors_writer_;
  Writer feedback_writer_;
  fl_LineSensors sensors_sample_{};
  fl_DriveFeedback feedback_sample_{};
  std::uint64_t write_failures_ = 0;
};

// One received command with its stamps (Cyclone's clock, dds_time()).
struct ReceivedCommand {
  OutputImage out{};           // the actuator part; state and faults stay default
  std::int64_t time_ns = 0;    // the controller's scan time (CLOCK_MONOTONIC)
  std::uint64_t scan = 0;      // the controller's scan counter
  std::int64_t source_ns = 0;  // the controller's dds_write
  std::int64_t arrival_ns = 0;
};

// Line I/O side: the controller's newest LineCommand.
class DdsCommandInput {
 public:
  explicit DdsCommandInput(const Participant& participant,
                           std::int64_t scan_period_ns = kScanPeriodNs);
  ~DdsCommandInput();
  DdsCommandInput(const DdsCommandInput&) = delete;
  DdsCommandInput& operator=(const DdsCommandInput&) = delete;

  // Any one consumer thread: true when a newer command arrived since the last call; `command`
  // holds the newest one either way (default before the first).
  bool read(ReceivedCommand& command) noexcept;

  [[nodiscard]] std::uint64_t commands_received() const noexcept {
    return received_.load(std::memory_order_relaxed);
  }
  [[nodiscard]] std::uint32_t matched_writers() const { return reader_.matched_writers(); }
  // dds_write in the controller -> taken here.
  [[nodiscard]] DistributionSummary transport_latency() const;

 private:
  static void on_command(dds_entity_t reader, void* arg);

  TripleBuffer<ReceivedCommand> commands_;
  std::atomic<std::uint64_t> received_{0};
  mutable std::mutex mutex_;  // listener thread and transport_latency()
  fl_LineCommand sample_{};
  DurationHistogram transport_{1'000, 100'000'000};  // 1 us bins to 100 ms

  Topic topic_;
  Reader reader_;  // last: created when everything above exists, deleted first
};

}  // namespace fl::drivers::dds
