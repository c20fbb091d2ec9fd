#include "fl/drivers/dds/line_io.hpp"

#include <spdlog/spdlog.h>

#include <bit>
#include <ctime>

#include "fl/controller/monotonic_clock.hpp"
#include "fl/drivers/dds/convert.hpp"

namespace fl::drivers::dds {
namespace {

Listener data_listener(void* self, dds_on_data_available_fn data) {
  Listener listener = make_listener(self);
  dds_lset_data_available(listener.get(), data);
  return listener;
}

}  // namespace

// ------------------------------------------------------------------ DdsSensorInput

DdsSensorInput::DdsSensorInput(const Participant& participant, std::int64_t scan_period_ns)
    : sensors_topic_(participant, fl_LineSensors_desc, kSensorsTopic),
      feedback_topic_(participant, fl_DriveFeedback_desc, kFeedbackTopic),
      sensors_reader_(participant, sensors_topic_, sensors_qos(scan_period_ns).get(),
                      data_listener(this, &on_sensors).get()),
      feedback_reader_(participant, feedback_topic_, feedback_qos().get(),
                       data_listener(this, &on_feedback).get()) {}

DdsSensorInput::~DdsSensorInput() = default;  // the readers are the last members

void DdsSensorInput::read(InputImage& in) noexcept {
  sensors_.update();
  // Validated on intake: from_idl cannot refuse here. Before the first sample the buffer holds
  // zeros, estop_ok false among them: a controller that has heard nothing sees an open chain.
  (void)from_idl(sensors_.front(), in);
  for (std::size_t d = 0; d < kDriveCount; ++d) {
    drives_[d].update();
    in.drives[d] = drives_[d].front();
  }
}

SensorInputCounters DdsSensorInput::counters() const noexcept {
  return {sensors_accepted_.load(std::memory_order_relaxed),
          sensors_rejected_.load(std::memory_order_relaxed),
          feedback_accepted_.load(std::memory_order_relaxed),
          feedback_rejected_.load(std::memory_order_relaxed)};
}

void DdsSensorInput::on_sensors(dds_entity_t reader, void* arg) {
  auto& self = *static_cast<DdsSensorInput*>(arg);
  const std::lock_guard lock(self.sensors_mutex_);
  void* pointer = &self.sensors_sample_;
  dds_sample_info_t info{};
  // One at a time into our own sample (fixed-size type: no allocation); keep-last 1 means
  // there is rarely more than one.
  while (dds_take(reader, &pointer, &info, 1, 1) > 0) {
    if (!info.valid_data) continue;
    InputImage probe;
    if (!from_idl(self.sensors_sample_, probe)) {
      const std::uint64_t count =
          self.sensors_rejected_.fetch_add(1, std::memory_order_relaxed) + 1;
      if (std::has_single_bit(count)) {
        spdlog::warn("dds: LineSensors sample rejected: a value is not finite ({} so far)", count);
      }
      continue;
    }
    self.sensors_.back() = self.sensors_sample_;
    self.sensors_.publish();
    self.sensors_accepted_.fetch_add(1, std::memory_order_relaxed);
    self.last_sensors_arrival_ns_.store(monotonic_now_ns(), std::memory_order_release);
  }
}

void DdsSensorInput::on_feedback(dds_entity_t reader, void* arg) {
  auto& self = *static_cast<DdsSensorInput*>(arg);
  const std::lock_guard lock(self.feedback_mutex_);
  std::array<void*, kDriveCount> pointers{};
  std::array<dds_sample_info_t, kDriveCount> infos{};
  for (std::size_t i = 0; i < kDriveCount; ++i) pointers[i] = &self.feedback_samples_[i];
  for (;;) {
    const dds_return_t taken =
        dds_take(reader, pointers.data(), infos.data(), kDriveCount, kDriveCount);
    if (taken <= 0) return;
    for (std::size_t i = 0; i < static_cast<std::size_t>(taken); ++i) {
      if (!infos[i].valid_data) continue;
      DriveId drive{};
      DriveFeedback feedback;
      if (!from_idl(self.feedback_samples_[i], drive, feedback)) {
        const std::uint64_t count =
            self.feedback_rejected_.fetch_add(1, std::memory_order_relaxed) + 1;
        if (std::has_single_bit(count)) {
          spdlog::warn("dds: DriveFeedback sample rejected: drive id {} out of range ({} so far)",
                       static_cast<unsigned>(self.feedback_samples_[i].drive_id), count);
        }
        continue;
      }
      TripleBuffer<DriveFeedback>& buffer = self.drives_[index(drive)];
      buffer.back() = feedback;
      buffer.publish();
      self.feedback_accepted_.fetch_add(1, std::memory_order_relaxed);
    }
    if (static_cast<std::size_t>(taken) < kDriveCount) return;
  }
}

// ------------------------------------------------------------------ DdsSensorPublisher

DdsSensorPublisher::DdsSensorPublisher(const Participant& participant, std::int64_t scan_period_ns)
    : sensors_topic_(participant, fl_LineSensors_desc, kSensorsTopic),
      feedback_topic_(participant, fl_DriveFeedback_desc, kFeedbackTopic),
      sensors_writer_(participant, sensors_topic_, sensors_qos(scan_period_ns).get()),
      feedback_writer_(participant, feedback_topic_, feedback_qos().get()) {}

bool DdsSensorPublisher::publish(std::uint64_t scan, const InputImage& in) {
  bool ok = true;
  // Drives first: a controller that sees the new sensors sample also has this scan's encoders
  // (each sample is delivered in write order on loopback).
  for (std::size_t d = 0; d < kDriveCount; ++d) {
    to_idl(static_cast<DriveId>(d), in.time_ns, in.drives[d], feedback_sample_);
    ok = feedback_writer_.write(feedback_sample_) >= 0 && ok;
  }
  to_idl(scan, in, sensors_sample_);
  ok = sensors_writer_.write(sensors_sample_) >= 0 && ok;
  if (!ok) ++write_failures_;
  return ok;
}

// ------------------------------------------------------------------ DdsCommandInput

DdsCommandInput::DdsCommandInput(const Participant& participant, std::int64_t scan_period_ns)
    : topic_(participant, fl_LineCommand_desc, kCommandTopic),
      reader_(participant, topic_, command_qos(scan_period_ns).get(),
              data_listener(this, &on_command).get()) {}

DdsCommandInput::~DdsCommandInput() = default;  // reader_ is the last member

bool DdsCommandInput::read(ReceivedCommand& command) noexcept {
  const bool fresh = commands_.update();
  command = commands_.front();
  return fresh;
}

DistributionSummary DdsCommandInput::transport_latency() const {
  const std::lock_guard lock(mutex_);
  return transport_.summary();
}

void DdsCommandInput::on_command(dds_entity_t reader, void* arg) {
  auto& self = *static_cast<DdsCommandInput*>(arg);
  const std::lock_guard lock(self.mutex_);
  void* pointer = &self.sample_;
  dds_sample_info_t info{};
  while (dds_take(reader, &pointer, &info, 1, 1) > 0) {
    if (!info.valid_data) continue;
    const std::int64_t arrival_ns = dds_time();
    ReceivedCommand& command = self.commands_.back();
    command.out = OutputImage{};
    from_idl(self.sample_, command.out);
    command.time_ns = self.sample_.time_ns;
    command.scan = self.sample_.scan;
    command.source_ns = info.source_timestamp;
    command.arrival_ns = arrival_ns;
    self.commands_.publish();
    self.transport_.record(arrival_ns - info.source_timestamp);
    self.received_.fetch_add(1, std::memory_order_relaxed);
  }
}

}  // namespace fl::drivers::dds
