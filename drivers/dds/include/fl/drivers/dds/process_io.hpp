// The controller's process image with DDS: a ProcessIo for the real ScanRuntime that reads
// camera estimates (DdsCameraInput) and writes commands and status (DdsLineOutput). The line's
// sensors and drive feedback come either over DDS too (DdsSensorInput: the twin's topics) or
// from the line's devices through another ProcessIo (the CANopen master, read before the
// cameras and written before the DDS command). The scan thread never calls Cyclone: read()
// and write() only copy from and into the parts' triple buffers (docs/dds.md, "Real-time
// contract"), so this composite keeps their guarantees.
//
// The sensors' safe reaction: when no LineSensors sample arrived for sensors_stale_ns (the
// line's I/O side died, hung or was never there), read() reports the safety chain open
// (estop_ok false), so the controller faults with kEstop and stops every drive, as a
// CANopen I/O node lost from the bus would. The frozen sample is never trusted longer.
#pragma once

#include <atomic>
#include <cstdint>

#include "fl/controller/cycle_stats.hpp"
#include "fl/controller/process_image.hpp"
#include "fl/controller/runtime.hpp"
#include "fl/drivers/dds/camera_input.hpp"
#include "fl/drivers/dds/line_io.hpp"
#include "fl/drivers/dds/line_output.hpp"

namespace fl::drivers::dds {

struct DdsProcessIoOptions {
  // 20 scans: longer than any scheduling hiccup measured on a loaded development machine
  // (docs/dds.md, two-process mode) so that jitter alone never stops the line, and short
  // enough that the belts stop within a fifth of a second of losing the I/O side.
  std::int64_t sensors_stale_ns = 200'000'000;
};

class DdsProcessIo final : public ProcessIo {
 public:
  DdsProcessIo(DdsCameraInput& cameras, DdsSensorInput& sensors, DdsLineOutput& output,
               DdsProcessIoOptions options = {});
  // The line's devices on `devices` (it owns their safe reactions); no sensor staleness here.
  DdsProcessIo(DdsCameraInput& cameras, ProcessIo& devices, DdsLineOutput& output);

  // Scan thread, real-time.
  void read(std::int64_t now_ns, InputImage& in) override;
  void write(const OutputImage& out) override;

  // Any thread.
  [[nodiscard]] LineState state() const noexcept { return state_.load(std::memory_order_acquire); }
  [[nodiscard]] std::uint32_t active_faults() const noexcept {
    return faults_.load(std::memory_order_relaxed);
  }
  [[nodiscard]] std::int64_t last_scan_time_ns() const noexcept {
    return last_scan_ns_.load(std::memory_order_relaxed);
  }
  // Scans that saw the sensors stale (and so the safety chain open); 0 with `devices`.
  [[nodiscard]] std::uint64_t sensors_stale_scans() const noexcept {
    return stale_scans_.load(std::memory_order_relaxed);
  }
  // With `devices` whose transport stamps its writes (ProcessIo::last_write_applied_ns):
  // from each camera frame's publication to the command of the first scan that read it
  // taking effect at the devices (CAN: the SYNC on the wire). Read after the runtime stopped.
  [[nodiscard]] DistributionSummary estimate_to_devices() const {
    return estimate_to_devices_.summary();
  }
  // Frames whose command the devices' transport could not stamp (not measured).
  [[nodiscard]] std::uint64_t estimates_unstamped() const { return estimates_unstamped_; }

 private:
  void record_estimate_to_devices();

  DdsCameraInput& cameras_;
  DdsSensorInput* sensors_ = nullptr;  // exactly one of these two
  ProcessIo* devices_ = nullptr;
  DdsLineOutput& output_;
  const DdsProcessIoOptions options_;
  FrameStamps stamps_{};      // scan thread's own: the frames this scan read
  FrameStamps awaiting_{};    // scan thread's own: frames whose command the devices have
  std::int64_t scan_ns_ = 0;  // scan thread's own
  DurationHistogram estimate_to_devices_{10'000, 200'000'000};  // 10 us bins up to 200 ms
  std::uint64_t estimates_unstamped_ = 0;
  std::atomic<LineState> state_{LineState::kStopped};
  std::atomic<std::uint32_t> faults_{0};
  std::atomic<std::int64_t> last_scan_ns_{0};
  std::atomic<std::uint64_t> stale_scans_{0};
};

}  // namespace fl::drivers::dds
