#include "fl/drivers/dds/process_io.hpp"

#include "fl/controller/monotonic_clock.hpp"

namespace fl::drivers::dds {

DdsProcessIo::DdsProcessIo(DdsCameraInput& cameras, DdsSensorInput& sensors, DdsLineOutput& output,
                           DdsProcessIoOptions options)
    : cameras_(cameras), sensors_(&sensors), output_(output), options_(options) {}

DdsProcessIo::DdsProcessIo(DdsCameraInput& cameras, ProcessIo& devices, DdsLineOutput& output)
    : cameras_(cameras), devices_(&devices), output_(output), options_() {}

void DdsProcessIo::read(std::int64_t now_ns, InputImage& in) {
  scan_ns_ = now_ns;
  if (devices_ != nullptr) {
    devices_->read(now_ns, in);
    record_estimate_to_devices();
    cameras_.read(in, stamps_);
  } else {
    cameras_.read(in, stamps_);
    sensors_->read(in);
    // Both stamps are CLOCK_MONOTONIC; the arrival may be a little after the scheduled time.
    const std::int64_t arrival_ns = sensors_->last_sensors_arrival_ns();
    const bool stale = arrival_ns == 0 || now_ns - arrival_ns > options_.sensors_stale_ns;
    if (stale) {
      in.estop_ok = false;
      stale_scans_.fetch_add(1, std::memory_order_relaxed);
    }
  }
  last_scan_ns_.store(now_ns, std::memory_order_relaxed);
}

void DdsProcessIo::record_estimate_to_devices() {
  if (awaiting_.fresh_mask == 0) return;
  const std::optional<std::int64_t> applied_ns = devices_->last_write_applied_ns();
  // Publication stamps are DDS time (CLOCK_REALTIME), the devices' on CLOCK_MONOTONIC.
  const std::int64_t realtime_minus_monotonic_ns = dds_time() - monotonic_now_ns();
  for (std::size_t c = 0; c < kCameraCount; ++c) {
    if ((awaiting_.fresh_mask & (1U << c)) == 0 || awaiting_.source_ns[c] <= 0) continue;
    if (applied_ns) {
      estimate_to_devices_.record(*applied_ns + realtime_minus_monotonic_ns -
                                  awaiting_.source_ns[c]);
    } else {
      ++estimates_unstamped_;
    }
  }
  awaiting_.fresh_mask = 0;
}

void DdsProcessIo::write(const OutputImage& out) {
  if (devices_ != nullptr) {
    devices_->write(out);  // the drives' commands first
    awaiting_ = stamps_;   // their time at the devices is known after the next read()
  }
  output_.write(scan_ns_, out, stamps_);
  stamps_.fresh_mask = 0;  // a frame's reaction is the first command after it, only
  faults_.store(out.active_faults, std::memory_order_relaxed);
  state_.store(out.state, std::memory_order_release);
}

}  // namespace fl::drivers::dds
