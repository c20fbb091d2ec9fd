#include "fl/drivers/dds/camera_input.hpp"

#include <spdlog/spdlog.h>

#include <bit>
#include <ctime>

#include "fl/controller/monotonic_clock.hpp"

namespace fl::drivers::dds {
namespace {

// Log the 1st, 2nd, 4th, 8th ... occurrence: a flooding peer cannot flood the log, and the
// count in the message still says how bad it is.
bool worth_logging(std::uint64_t count) noexcept { return std::has_single_bit(count); }

const char* policy_name(std::uint32_t id) noexcept {
  switch (id) {
    case DDS_RELIABILITY_QOS_POLICY_ID:
      return "reliability";
    case DDS_DEADLINE_QOS_POLICY_ID:
      return "deadline";
    case DDS_LIVELINESS_QOS_POLICY_ID:
      return "liveliness";
    case DDS_DURABILITY_QOS_POLICY_ID:
      return "durability";
    case DDS_DESTINATIONORDER_QOS_POLICY_ID:
      return "destination order";
    default:
      return "other";
  }
}

Listener make_camera_listener(void* self, dds_on_data_available_fn data,
                              dds_on_requested_deadline_missed_fn deadline,
                              dds_on_liveliness_changed_fn liveliness,
                              dds_on_requested_incompatible_qos_fn incompatible) {
  Listener listener = make_listener(self);
  dds_lset_data_available(listener.get(), data);
  dds_lset_requested_deadline_missed(listener.get(), deadline);
  dds_lset_liveliness_changed(listener.get(), liveliness);
  dds_lset_requested_incompatible_qos(listener.get(), incompatible);
  return listener;
}

}  // namespace

std::uint64_t IntakeCounters::rejected_total() const noexcept {
  std::uint64_t total = 0;
  for (const std::uint64_t count : rejected) total += count;
  return total;
}

DdsCameraInput::DdsCameraInput(const Participant& participant, CameraInputOptions options)
    : options_(options),
      topic_(participant, fl_CameraEstimates_desc, options.topic),
      reader_(participant, topic_, estimates_qos(options.slowest_camera_period_ns).get(),
              make_camera_listener(this, &on_data_available, &on_deadline_missed,
                                   &on_liveliness_changed, &on_incompatible_qos)
                  .get()) {}

DdsCameraInput::~DdsCameraInput() = default;  // reader_ is the last member: deleted first

void DdsCameraInput::read(InputImage& in) noexcept {
  for (std::size_t c = 0; c < kCameraCount; ++c) {
    CameraSlot& slot = slots_[c];
    slot.frames.update();
    in.cameras[c] = slot.frames.front().frame;
  }
}

void DdsCameraInput::read(InputImage& in, FrameStamps& stamps) noexcept {
  stamps.fresh_mask = 0;
  for (std::size_t c = 0; c < kCameraCount; ++c) {
    CameraSlot& slot = slots_[c];
    if (slot.frames.update()) stamps.fresh_mask |= 1U << c;
    const StampedFrame& front = slot.frames.front();
    in.cameras[c] = front.frame;
    stamps.source_ns[c] = front.source_ns;
    stamps.arrival_ns[c] = front.arrival_ns;
  }
}

CameraHealth DdsCameraInput::health(CameraId camera) const noexcept {
  const CameraSlot& slot = slots_[index(camera)];
  CameraHealth health;
  health.delivered = slot.delivered.load(std::memory_order_acquire);
  health.writer_alive = slot.writer_alive.load(std::memory_order_acquire);
  health.deadline_missed = slot.deadline_missed.load(std::memory_order_acquire);
  health.frames_accepted = slot.frames_accepted.load(std::memory_order_relaxed);
  health.deadlines_missed = slot.deadlines_missed.load(std::memory_order_relaxed);
  health.writers_lost = slot.writers_lost.load(std::memory_order_relaxed);
  return health;
}

std::uint32_t DdsCameraInput::stale_mask() const noexcept {
  std::uint32_t mask = 0;
  for (std::size_t c = 0; c < kCameraCount; ++c) {
    if (health(static_cast<CameraId>(c)).stale()) mask |= 1U << c;
  }
  return mask;
}

IntakeCounters DdsCameraInput::counters() const noexcept {
  IntakeCounters counters;
  counters.samples_taken = samples_taken_.load(std::memory_order_relaxed);
  counters.samples_accepted = samples_accepted_.load(std::memory_order_relaxed);
  for (std::size_t r = 0; r < kRejectReasonCount; ++r) {
    counters.rejected[r] = rejected_[r].load(std::memory_order_relaxed);
  }
  counters.incompatible_qos = incompatible_qos_.load(std::memory_order_relaxed);
  counters.liveliness_lost = liveliness_lost_.load(std::memory_order_relaxed);
  counters.deadlines_missed = deadlines_missed_.load(std::memory_order_relaxed);
  return counters;
}

void DdsCameraInput::on_data_available(dds_entity_t reader, void* arg) {
  static_cast<DdsCameraInput*>(arg)->take_all(reader);
}

void DdsCameraInput::take_all(dds_entity_t reader) {
  // One taker at a time: Cyclone may deliver from its receive thread and from a local
  // writer's thread at once, and the preallocated samples and triple buffers have one
  // producer.
  const std::lock_guard lock(intake_mutex_);
  for (std::size_t i = 0; i < kTakeBatch; ++i) sample_pointers_[i] = &samples_[i];
  for (;;) {
    // Into our own samples, not a loan: the type is fixed size, so nothing is allocated.
    const dds_return_t taken =
        dds_take(reader, sample_pointers_.data(), infos_.data(), kTakeBatch, kTakeBatch);
    if (taken <= 0) return;
    for (std::size_t i = 0; i < static_cast<std::size_t>(taken); ++i) {
      const dds_sample_info_t& info = infos_[i];
      if (info.valid_data) {
        samples_taken_.fetch_add(1, std::memory_order_relaxed);
        if (const auto reason = validate(samples_[i])) {
          reject(*reason, samples_[i]);
        } else {
          accept(samples_[i], info);
        }
      } else if (info.instance_state != DDS_IST_ALIVE) {
        // No data, only news: the camera's instance has no live writer any more (all its
        // writers lost liveliness or left) or was disposed.
        for (std::size_t c = 0; c < kCameraCount; ++c) {
          if (slots_[c].instance.load(std::memory_order_relaxed) == info.instance_handle) {
            mark_writer_lost(slots_[c], c);
          }
        }
      }
    }
    if (static_cast<std::size_t>(taken) < kTakeBatch) return;
  }
}

void DdsCameraInput::accept(const fl_CameraEstimates& sample, const dds_sample_info_t& info) {
  CameraSlot& slot = slots_[sample.camera_id];
  StampedFrame& stamped = slot.frames.back();
  from_idl(sample, stamped.frame);
  stamped.source_ns = info.source_timestamp;
  stamped.arrival_ns = dds_time();
  slot.frames.publish();
  slot.instance.store(info.instance_handle, std::memory_order_relaxed);
  slot.publication.store(info.publication_handle, std::memory_order_relaxed);
  slot.last_arrival_ns.store(monotonic_now_ns(), std::memory_order_relaxed);
  slot.frames_accepted.fetch_add(1, std::memory_order_relaxed);
  slot.delivered.store(true, std::memory_order_release);
  slot.deadline_missed.store(false, std::memory_order_release);
  if (info.instance_state != DDS_IST_ALIVE) {
    // A frame written just before its writer died or left: valid data, but nobody is
    // behind it any more.
    mark_writer_lost(slot, sample.camera_id);
  } else if (!slot.writer_alive.exchange(true, std::memory_order_acq_rel)) {
    spdlog::info("dds: camera {} delivering (frame {})", static_cast<unsigned>(sample.camera_id),
                 sample.frame_sequence);
  }
  samples_accepted_.fetch_add(1, std::memory_order_relaxed);
}

void DdsCameraInput::reject(RejectReason reason, const fl_CameraEstimates& sample) {
  const std::uint64_t count =
      rejected_[static_cast<std::size_t>(reason)].fetch_add(1, std::memory_order_relaxed) + 1;
  if (worth_logging(count)) {
    spdlog::warn("dds: estimates sample rejected: {} (camera id {}, count {}, frame {}); {} so far",
                 to_string(reason), static_cast<unsigned>(sample.camera_id),
                 static_cast<unsigned>(sample.count), sample.frame_sequence, count);
  }
}

void DdsCameraInput::mark_writer_lost(CameraSlot& slot, std::size_t camera) {
  if (slot.writer_alive.exchange(false, std::memory_order_acq_rel)) {
    slot.writers_lost.fetch_add(1, std::memory_order_relaxed);
    spdlog::warn("dds: camera {} has no live writer: stale", camera);
  }
}

void DdsCameraInput::on_deadline_missed(dds_entity_t /*reader*/,
                                        dds_requested_deadline_missed_status_t status, void* arg) {
  auto& self = *static_cast<DdsCameraInput*>(arg);
  const auto change =
      static_cast<std::uint64_t>(status.total_count_change > 0 ? status.total_count_change : 0);
  self.deadlines_missed_.fetch_add(change, std::memory_order_relaxed);
  // Cyclone names only the last instance; a callback may stand for several, so also mark
  // every camera whose last frame is older than the deadline.
  const std::int64_t deadline_ns =
      kEstimateDeadlinePeriods * self.options_.slowest_camera_period_ns;
  const std::int64_t now_ns = monotonic_now_ns();
  for (std::size_t c = 0; c < kCameraCount; ++c) {
    CameraSlot& slot = self.slots_[c];
    if (!slot.delivered.load(std::memory_order_acquire)) continue;
    const bool named = slot.instance.load(std::memory_order_relaxed) == status.last_instance_handle;
    const bool overdue =
        now_ns - slot.last_arrival_ns.load(std::memory_order_relaxed) > deadline_ns;
    if (!named && !overdue) continue;
    slot.deadlines_missed.fetch_add(1, std::memory_order_relaxed);
    if (!slot.deadline_missed.exchange(true, std::memory_order_acq_rel)) {
      spdlog::warn("dds: camera {} missed its {} ms deadline: stale", c, deadline_ns / 1'000'000);
    }
  }
}

void DdsCameraInput::on_liveliness_changed(dds_entity_t /*reader*/,
                                           dds_liveliness_changed_status_t status, void* arg) {
  auto& self = *static_cast<DdsCameraInput*>(arg);
  if (status.not_alive_count_change > 0) {
    const std::uint64_t count = self.liveliness_lost_.fetch_add(1, std::memory_order_relaxed) + 1;
    if (worth_logging(count)) {
      spdlog::warn("dds: an estimates writer lost liveliness ({} so far)", count);
    }
  }
  if (status.alive_count_change >= 0) return;
  // A writer lost liveliness or left: every camera it was the last writer of is stale.
  for (std::size_t c = 0; c < kCameraCount; ++c) {
    CameraSlot& slot = self.slots_[c];
    if (slot.publication.load(std::memory_order_relaxed) == status.last_publication_handle) {
      self.mark_writer_lost(slot, c);
    }
  }
}

void DdsCameraInput::on_incompatible_qos(dds_entity_t /*reader*/,
                                         dds_requested_incompatible_qos_status_t status,
                                         void* arg) {
  auto& self = *static_cast<DdsCameraInput*>(arg);
  self.incompatible_qos_.fetch_add(
      static_cast<std::uint64_t>(status.total_count_change > 0 ? status.total_count_change : 0),
      std::memory_order_relaxed);
  spdlog::error("dds: an estimates writer offers incompatible QoS ({}): not matched",
                policy_name(status.last_policy_id));
}

}  // namespace fl::drivers::dds
