// The cameras' estimates, from DDS into the controller's input image.
//
// Cyclone delivers samples on its own receive thread (or on a local writer's thread), and
// its take() locks the reader's cache, so the scan thread never calls into Cyclone: the
// reader's data-available listener takes into preallocated samples (the IDL type is fixed
// size, so deserialising allocates nothing), validates and converts them, and publishes each
// camera's newest frame through a wait-free triple buffer. read() on the scan thread only
// swaps buffer indices and copies: no allocation, no lock, no system call.
//
// Staleness: the input image's notion of a silent camera is the frame's sequence and
// frame_time_ns (the tracker ignores a sequence it has seen and refuses frames older than
// the camera's max_age_s; the controller raises FaultCode::kCameraSilent after
// max(max_age_s, 5 periods) without a new frame). DdsCameraInput never fabricates a frame:
// when a camera's deadline is missed or its writer's liveliness is lost the image keeps
// the camera's last frame, whose sequence the tracker has already seen, so the controller's
// own staleness rule takes over. health() reports the DDS side of it (deadline missed, no
// live writer) for diagnostics, LineStatus.camera_stale_mask and logs.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <mutex>

#include "fillet_line.h"
#include "fl/controller/process_image.hpp"
#include "fl/drivers/dds/convert.hpp"
#include "fl/drivers/dds/entity.hpp"
#include "fl/drivers/dds/qos.hpp"
#include "fl/drivers/dds/triple_buffer.hpp"

namespace fl::drivers::dds {

struct CameraInputOptions {
  // The reader's deadline and liveliness lease are kEstimate*Periods of this period.
  std::int64_t slowest_camera_period_ns = kSlowestCameraPeriodNs;
  const char* topic = kEstimatesTopic;
};

struct CameraHealth {
  bool delivered = false;        // at least one valid frame since start
  bool writer_alive = false;     // the instance has a live writer
  bool deadline_missed = false;  // no frame within the deadline since the last one
  [[nodiscard]] bool stale() const noexcept {
    return !delivered || !writer_alive || deadline_missed;
  }
  std::uint64_t frames_accepted = 0;
  std::uint64_t deadlines_missed = 0;  // Cyclone's count for this camera's instance
  std::uint64_t writers_lost = 0;      // times the instance lost its last live writer
};

// When the frames that read() hands over were published and received, for latency
// measurements (two-process mode: camera frame published -> command that reacts to it). On
// Cyclone's clock (dds_time(): CLOCK_REALTIME), which a writer and a reader on one host share.
struct FrameStamps {
  std::uint32_t fresh_mask = 0;  // bit c: camera c's frame arrived since the previous read()
  std::array<std::int64_t, kCameraCount> source_ns{};   // the writer's dds_write
  std::array<std::int64_t, kCameraCount> arrival_ns{};  // taken by the listener
};

struct IntakeCounters {
  std::uint64_t samples_taken = 0;  // valid samples, accepted or not
  std::uint64_t samples_accepted = 0;
  std::array<std::uint64_t, kRejectReasonCount> rejected{};  // by RejectReason
  std::uint64_t incompatible_qos = 0;  // writers refused for their QoS (requested side)
  std::uint64_t liveliness_lost = 0;   // writers that lost liveliness
  std::uint64_t deadlines_missed = 0;  // all cameras
  [[nodiscard]] std::uint64_t rejected_total() const noexcept;
};

class DdsCameraInput {
 public:
  DdsCameraInput(const Participant& participant, CameraInputOptions options = {});
  ~DdsCameraInput();  // deletes the reader first, so no listener runs on a dead object
  DdsCameraInput(const DdsCameraInput&) = delete;
  DdsCameraInput& operator=(const DdsCameraInput&) = delete;

  // Scan thread, real-time: copies every camera's newest frame into in.cameras.
  void read(InputImage& in) noexcept;
  // The same, and when each frame was published and taken.
  void read(InputImage& in, FrameStamps& stamps) noexcept;

  // Any thread.
  [[nodiscard]] CameraHealth health(CameraId camera) const noexcept;
  // Bit c set: camera c is stale (CameraHealth::stale()).
  [[nodiscard]] std::uint32_t stale_mask() const noexcept;
  [[nodiscard]] IntakeCounters counters() const noexcept;
  [[nodiscard]] std::uint32_t matched_writers() const { return reader_.matched_writers(); }
  [[nodiscard]] dds_entity_t reader() const noexcept { return reader_.get(); }

  static constexpr std::size_t kTakeBatch = 16;  // two frames of every camera per take

 private:
  struct StampedFrame {
    CameraFrame frame;
    std::int64_t source_ns = 0;
    std::int64_t arrival_ns = 0;
  };
  struct CameraSlot {
    TripleBuffer<StampedFrame> frames;
    std::atomic<bool> delivered{false};
    std::atomic<bool> writer_alive{false};
    std::atomic<bool> deadline_missed{false};
    std::atomic<std::uint64_t> frames_accepted{0};
    std::atomic<std::uint64_t> deadlines_missed{0};
    std::atomic<std::uint64_t> writers_lost{0};
    // Listener side: atomics because the deadline and liveliness callbacks run on other
    // Cyclone threads than data-available and must not take intake_mutex_ (lock order).
    std::atomic<dds_instance_handle_t> instance{0};
    std::atomic<dds_instance_handle_t> publication{0};
    std::atomic<std::int64_t> last_arrival_ns{0};
  };

  static void on_data_available(dds_entity_t reader, void* arg);
  static void on_deadline_missed(dds_entity_t reader, dds_requested_deadline_missed_status_t status,
                                 void* arg);
  static void on_liveliness_changed(dds_entity_t reader, dds_liveliness_changed_status_t status,
                                    void* arg);
  static void on_incompatible_qos(dds_entity_t reader,
                                  dds_requested_incompatible_qos_status_t status, void* arg);
  void take_all(dds_entity_t reader);
  void accept(const fl_CameraEstimates& sample, const dds_sample_info_t& info);
  void reject(RejectReason reason, const fl_CameraEstimates& sample);
  void mark_writer_lost(CameraSlot& slot, std::size_t camera);

  const CameraInputOptions options_;
  std::array<CameraSlot, kCameraCount> slots_{};

  std::mutex intake_mutex_;  // listener threads only; the scan thread never takes it
  std::array<fl_CameraEstimates, kTakeBatch> samples_{};
  std::array<void*, kTakeBatch> sample_pointers_{};
  std::array<dds_sample_info_t, kTakeBatch> infos_{};

  std::atomic<std::uint64_t> samples_taken_{0};
  std::atomic<std::uint64_t> samples_accepted_{0};
  std::array<std::atomic<std::uint64_t>, kRejectReasonCount> rejected_{};
  std::atomic<std::uint64_t> incompatible_qos_{0};
  std::atomic<std::uint64_t> liveliness_lost_{0};
  std::atomic<std::uint64_t> deadlines_missed_{0};

  Topic topic_;
  Reader reader_;  // last: created when everything above exists, deleted first
};

}  // namespace fl::drivers::dds
