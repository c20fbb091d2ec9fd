#include "fl/controller/line_status.hpp"

#include <algorithm>
#include <span>

namespace fl {

void LineStatusPublisher::publish(const LineController& controller, const InputImage& in,
                                  const OutputImage& out, const ScanTimingSample& timing) noexcept {
  LineStatus& status = buffer_.back();
  status.sequence = ++sequence_;
  status.time_ns = in.time_ns;
  status.state = out.state;
  status.active_faults = out.active_faults;
  status.estop_ok = in.estop_ok;
  for (std::size_t d = 0; d < kDriveCount; ++d) {
    DriveStatus& drive = status.drives[d];
    drive.command_mps = out.drives[d].speed_mps;
    drive.enabled = out.drives[d].enable;
    drive.speed_mps = in.drives[d].speed_mps;
    drive.ready = in.drives[d].ready;
    drive.fault = in.drives[d].fault;
  }
  status.flip_plate1_flip = out.flip_plate1_flip;
  status.flip_plate2_flip = out.flip_plate2_flip;
  status.flip_plate1_flipping = in.flip_plate1_flipping;
  status.flip_plate2_flipping = in.flip_plate2_flipping;
  status.reject_reversing = out.drives[index(DriveId::kReject)].speed_mps < 0.0F;
  status.final_reject = out.final_reject;
  status.centring_stroke = out.centring_stroke;
  status.centring_shift_mm = out.centring_shift_mm;
  status.squeeze_roller_down = out.squeeze_roller_down;
  status.level_mm = in.level_mm;
  status.hopper_opening_mm = in.hopper_opening_mm;
  status.leveller_speed_rpm = in.leveller_speed_rpm;

  status.counters = controller.counters();
  status.records_dropped = controller.records_dropped();
  status.events_dropped = controller.events_dropped();
  status.tracked_count = static_cast<std::uint32_t>(
      controller.tracked_items(std::span<TrackedItemView>(status.tracked)));

  window_latency_ns_ = std::max(window_latency_ns_, timing.wakeup_latency_ns);
  window_compute_ns_ = std::max(window_compute_ns_, timing.compute_ns);
  max_latency_ns_ = std::max(max_latency_ns_, timing.wakeup_latency_ns);
  max_compute_ns_ = std::max(max_compute_ns_, timing.compute_ns);
  if (++window_scans_ == kTimingWindowScans) {
    last_window_latency_ns_ = window_latency_ns_;
    last_window_compute_ns_ = window_compute_ns_;
    window_latency_ns_ = 0;
    window_compute_ns_ = 0;
    window_scans_ = 0;
  }
  ScanTimingStatus& shown = status.timing;
  shown.period_ns = timing.period_ns;
  shown.last_wakeup_latency_ns = timing.wakeup_latency_ns;
  shown.last_compute_ns = timing.compute_ns;
  // Before the first window completes, the one filling up is the best there is.
  const bool first_window = timing.scans <= kTimingWindowScans;
  shown.window_max_wakeup_latency_ns = first_window ? window_latency_ns_ : last_window_latency_ns_;
  shown.window_max_compute_ns = first_window ? window_compute_ns_ : last_window_compute_ns_;
  shown.max_wakeup_latency_ns = max_latency_ns_;
  shown.max_compute_ns = max_compute_ns_;
  shown.scans = timing.scans;
  shown.overruns = timing.overruns;
  buffer_.publish();
}

}  // namespace fl
