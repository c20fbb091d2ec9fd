#include "fl/controller/line_controller.hpp"

#include <algorithm>
#include <limits>

#include "stations.hpp"
#include "tracker.hpp"

namespace fl {

using logic::Item;
using logic::ScanContext;

namespace {
constexpr float kNsPerS = 1e9F;
// Drives must report ready this long after the start request, or the start faults.
constexpr float kStartTimeoutS = 3.0F;
// A controlled stop drains the line for at most this long, then stops what is left.
constexpr float kStopDrainTimeoutS = 30.0F;
// A camera that has delivered is silent after this many of its frame periods without a
// frame (and never sooner than its max age).
constexpr float kSilentPeriods = 5.0F;
// Sections meet end to start; float positions from YAML may differ by rounding.
constexpr float kSectionJoinToleranceMm = 1.0F;
// Faults that stop the whole line; the others degrade it (their reactions reject items).
// A drive fault stops its own section and those upstream at once; see drain_downstream().
constexpr std::uint32_t kLineStoppingFaults =
    fault_bit(FaultCode::kEstop) | fault_bit(FaultCode::kDriveFault) |
    fault_bit(FaultCode::kTrackerOverflow) | fault_bit(FaultCode::kCycleOverrun);
}  // namespace

struct LineController::Impl {
  explicit Impl(const LineConfig& line_config)
      : config(line_config),
        tracker(config),
        bulk(config),
        leveller(config),
        takt(config),
        flip(config),
        reject(config),
        centring(config),
        multilane(config),
        squeeze(config),
        final_station(config) {}

  void reset() {
    tracker.reset();
    bulk.reset();
    leveller.reset();
    takt.reset();
    flip.reset();
    reject.reset();
    multilane.reset();
    state = LineState::kStopped;
    faults = 0;
    latched_faults = 0;
    state_time_s = 0.0F;
    drain_from_mm = -std::numeric_limits<float>::infinity();
    drain_over = false;
    last_time_ns = 0;
    first_scan = true;
    start_requested = stop_requested = ack_requested = false;
    camera_flooded = {};
    counters = ControllerCounters{};
  }

  void change_state(LineState next, std::int64_t time_ns) {
    if (next == state) return;
    state = next;
    state_time_s = 0.0F;
    events.push(Event{time_ns, EventCode::kStateChanged, 0, static_cast<std::uint8_t>(next), 0.0F});
  }

  void set_fault(FaultCode code, bool active, std::int64_t time_ns, std::uint8_t source) {
    const std::uint32_t bit = fault_bit(code);
    const bool was = (faults & bit) != 0;
    if (active && !was) {
      faults |= bit;
      latched_faults |= bit;
      events.push(Event{time_ns, EventCode::kFaultRaised, 0, static_cast<std::uint8_t>(code),
                        static_cast<float>(source)});
    } else if (!active && was) {
      faults &= ~bit;
      events.push(Event{time_ns, EventCode::kFaultCleared, 0, static_cast<std::uint8_t>(code),
                        static_cast<float>(source)});
    }
  }

  void update_camera_faults(const InputImage& in, const ScanContext& ctx) {
    bool any_silent = false;
    std::uint8_t silent_camera = 0;
    bool any_flooded = false;
    std::uint8_t flooded_camera = 0;
    for (std::size_t c = 0; c < kCameraCount; ++c) {
      const auto camera = static_cast<CameraId>(c);
      const logic::FrameIntake intake = tracker.ingest(in, camera, events);
      // The flood fault lasts while a camera's newest frame is flooded, so that it clears
      // (and an acknowledge can reset its latch) once the camera delivers sane frames again.
      if (intake.new_frame) camera_flooded[c] = intake.flooded;
      if (camera_flooded[c] && !any_flooded) flooded_camera = static_cast<std::uint8_t>(c);
      any_flooded = any_flooded || camera_flooded[c];
      const CameraMount& mount = config.cameras[c];
      const float silent_after_s = std::max(mount.max_age_s, kSilentPeriods * mount.period_s);
      // Before a camera's first frame, silence counts from the start of running.
      const float silence_s =
          tracker.camera_has_delivered(camera)
              ? static_cast<float>(in.time_ns - tracker.last_frame_time_ns(camera)) / kNsPerS
              : (state == LineState::kRunning ? state_time_s : 0.0F);
      if (ctx.running && silence_s > silent_after_s) {
        if (!any_silent) silent_camera = static_cast<std::uint8_t>(c);
        any_silent = true;
      }
    }
    if (any_silent && (faults & fault_bit(FaultCode::kCameraSilent)) == 0) {
      events.push(Event{in.time_ns, EventCode::kCameraSilent, 0, silent_camera, 0.0F});
    }
    set_fault(FaultCode::kCameraSilent, any_silent, in.time_ns, silent_camera);
    set_fault(FaultCode::kEstimateFlood, any_flooded, in.time_ns, flooded_camera);
  }

  void update(const InputImage& in, OutputImage& out) {
    ++counters.scans;
    const float dt_s = first_scan ? 0.0F : static_cast<float>(in.time_ns - last_time_ns) / kNsPerS;
    first_scan = false;
    last_time_ns = in.time_ns;
    state_time_s += dt_s;
    out = OutputImage{};
    detect_overrun(dt_s, in.time_ns);

    tracker.advance(in);

    // Safety and drive faults first: they decide what the stations may do this scan.
    set_fault(FaultCode::kEstop, !in.estop_ok, in.time_ns, 0);
    bool drive_fault = false;
    std::uint8_t faulted_drive = 0;
    for (std::size_t d = 0; d < kDriveCount; ++d) {
      const bool enabled_and_not_ready =
          state == LineState::kRunning && !in.drives[d].ready && state_time_s > kStartTimeoutS;
      if (in.drives[d].fault || enabled_and_not_ready) {
        if (!drive_fault) faulted_drive = static_cast<std::uint8_t>(d);
        drive_fault = true;
        // The product path from the most downstream faulted section's end on may drain.
        drain_from_mm = std::max(drain_from_mm, section_end_mm(static_cast<DriveId>(d)));
      }
    }
    set_fault(FaultCode::kDriveFault, drive_fault, in.time_ns, faulted_drive);
    set_fault(FaultCode::kTrackerOverflow, tracker.overflows() > overflows_seen, in.time_ns, 0);
    overflows_seen = tracker.overflows();

    if (in.start_request) start_requested = true;
    if (in.stop_request) stop_requested = true;
    if (in.fault_reset_request) ack_requested = true;
    step_state_machine(in);

    // The overload contact acts in this scan; a jam seen from the blade speed in the next.
    if (in.leveller_overload) set_fault(FaultCode::kLevellerOverload, true, in.time_ns, 0);

    const bool draining = drain_downstream(in);
    const bool running = state == LineState::kStarting || state == LineState::kRunning ||
                         state == LineState::kStopping || draining;
    // The infeed stays off after a leveller fault until the operator acknowledges it.
    const bool infeed = state == LineState::kRunning &&
                        ((faults | latched_faults) & fault_bit(FaultCode::kLevellerOverload)) == 0;
    ScanContext ctx{in, dt_s, running, infeed, tracker, events, records, counters};
    update_camera_faults(in, ctx);

    bulk.update(ctx, out);
    const bool leveller_fault = leveller.update(ctx, out);
    set_fault(FaultCode::kLevellerOverload, leveller_fault, in.time_ns, 0);
    takt.update(ctx, out);
    for (DriveId drive : {DriveId::kTransition1, DriveId::kTransition2, DriveId::kCentring,
                          DriveId::kSqueeze, DriveId::kOutfeed}) {
      logic::set_drive(out, drive, config, config.sections[index(drive)].nominal_speed_mps,
                       running);
    }
    flip.update(ctx, out);
    bool hold_guide = false;
    reject.update(ctx, out, hold_guide);
    logic::set_drive(out, DriveId::kGuide, config,
                     hold_guide ? 0.0F : config.sections[index(DriveId::kGuide)].nominal_speed_mps,
                     running);
    centring.update(ctx, out);
    multilane.integrate_rotation(ctx);
    multilane.update(ctx, out);
    squeeze.update(ctx, out);
    final_station.update(ctx, out);

    if (!running) {
      // Stopped or faulted: every drive at standstill; with the safety chain open they are
      // disabled outright (their safe torque off follows the chain anyway).
      for (std::size_t d = 0; d < kDriveCount; ++d) {
        out.drives[d].speed_mps = 0.0F;
        out.drives[d].enable = state == LineState::kFault ? in.estop_ok : false;
      }
      out.leveller_speed_rpm = 0.0F;
      out.squeeze_roller_down = false;
      out.centring_stroke = false;
    } else if (draining) {
      // The faulted section and everything upstream of it stand (held, enabled); the
      // stations downstream work on as in a run.
      for (std::size_t d = 0; d < kDriveCount; ++d) {
        if (!downstream_of_drain(static_cast<DriveId>(d))) {
          out.drives[d].speed_mps = 0.0F;
          out.drives[d].enable = in.estop_ok;
        }
      }
      out.leveller_speed_rpm = 0.0F;
    }
    out.state = state;
    out.active_faults = faults | latched_faults;
    refresh_counters();
  }

  // A multilane unit's right drive moves its left drive's section (has_section()).
  static DriveId section_owner(DriveId drive) {
    if (drive == DriveId::kMultilane1Right) return DriveId::kMultilane1Left;
    if (drive == DriveId::kMultilane2Right) return DriveId::kMultilane2Left;
    return drive;
  }
  // Where a drive's part of the product path begins and ends: the bulk belt feeds s = 0.
  float section_end_mm(DriveId drive) const {
    return drive == DriveId::kBulk ? 0.0F : config.sections[index(section_owner(drive))].end_mm;
  }
  float section_start_mm(DriveId drive) const {
    return drive == DriveId::kBulk ? -std::numeric_limits<float>::infinity()
                                   : config.sections[index(section_owner(drive))].start_mm;
  }
  bool downstream_of_drain(DriveId drive) const {
    return section_start_mm(drive) >= drain_from_mm - kSectionJoinToleranceMm;
  }

  // A drive fault, and nothing else that stops the line, with the safety chain closed: the
  // belts downstream of the faulted section run on until the fillets on them have left the
  // line (placed or rejected as in a run, not stranded), within the stop drain time. Once
  // over, the drain stays over until the fault is acknowledged.
  bool drain_downstream(const InputImage& in) {
    if (state != LineState::kFault) {
      drain_over = false;
      drain_from_mm = -std::numeric_limits<float>::infinity();
      return false;
    }
    const std::uint32_t stopping = (faults | latched_faults) & kLineStoppingFaults;
    if (drain_over || stopping != fault_bit(FaultCode::kDriveFault) || !in.estop_ok ||
        state_time_s > kStopDrainTimeoutS) {
      drain_over = true;
      return false;
    }
    for (const Item& item : tracker.items()) {
      if (item.active && item.s_mm >= drain_from_mm) return true;
    }
    drain_over = true;
    return false;
  }

  void refresh_counters() {
    counters.outcomes = tracker.outcome_counts();
    counters.items_closed = closed_total();
    counters.estimates_rejected = tracker.rejected_estimates();
    counters.detections_unmatched = tracker.unmatched_detections();
    counters.detections_duplicate = tracker.duplicate_detections();
    counters.frames_processed = tracker.frames_processed();
    counters.items_adopted = tracker.adopted();
  }

  // The runtime passes the scheduled time, so a scan that skipped periods shows as a time
  // step longer than the period: deterministic, and the same in simulation.
  void detect_overrun(float dt_s, std::int64_t time_ns) {
    const float period_s = config.watchdog.cycle_period_s;
    if (dt_s > 1.5F * period_s) {
      ++counters.overruns;
      ++consecutive_overruns;
    } else if (dt_s > 0.0F) {
      consecutive_overruns = 0;
    }
    set_fault(FaultCode::kCycleOverrun,
              consecutive_overruns >= config.watchdog.overrun_fault_cycles, time_ns, 0);
  }

  std::uint64_t closed_total() const {
    std::uint64_t total = 0;
    for (std::size_t o = 0; o < kOutcomeCount; ++o) total += counters.outcomes[o];
    return total;
  }

  void step_state_machine(const InputImage& in) {
    if ((faults & kLineStoppingFaults) != 0) {
      change_state(LineState::kFault, in.time_ns);
    }
    switch (state) {
      case LineState::kStopped:
        if (start_requested && latched_faults == 0) change_state(LineState::kStarting, in.time_ns);
        break;
      case LineState::kStarting: {
        bool all_ready = true;
        for (const DriveFeedback& drive : in.drives) all_ready = all_ready && drive.ready;
        if (all_ready) change_state(LineState::kRunning, in.time_ns);
        if (!all_ready && state_time_s > kStartTimeoutS) {
          set_fault(FaultCode::kDriveFault, true, in.time_ns, 0);
          change_state(LineState::kFault, in.time_ns);
        }
        break;
      }
      case LineState::kRunning:
        if (stop_requested) change_state(LineState::kStopping, in.time_ns);
        break;
      case LineState::kStopping:
        if (tracker.active_count() == 0 || state_time_s > kStopDrainTimeoutS) {
          change_state(LineState::kStopped, in.time_ns);
        }
        break;
      case LineState::kFault:
        // Acknowledge clears latched faults whose cause is gone; the line restarts only on
        // a new start request.
        if (ack_requested) {
          latched_faults = faults;
          if ((faults & kLineStoppingFaults) == 0) change_state(LineState::kStopped, in.time_ns);
        }
        break;
    }
    if (state != LineState::kFault && ack_requested) latched_faults = faults;
    start_requested = stop_requested = ack_requested = false;
  }

  LineConfig config;
  logic::Tracker tracker;
  logic::BulkFeedStation bulk;
  logic::LevellerStation leveller;
  logic::TaktStation takt;
  logic::FlipStation flip;
  logic::RejectStation reject;
  logic::CentringStation centring;
  logic::MultilaneStation multilane;
  logic::SqueezeStation squeeze;
  logic::FinalStation final_station;
  RecordRing records;
  EventRing events;
  ControllerCounters counters;
  LineState state = LineState::kStopped;
  std::uint32_t faults = 0;
  std::uint32_t latched_faults = 0;
  std::uint64_t overflows_seen = 0;
  std::array<bool, kCameraCount> camera_flooded{};  // the camera's newest frame was flooded
  std::int32_t consecutive_overruns = 0;
  float state_time_s = 0.0F;
  // The drain after a drive fault: where it starts on the product path (the end of the most
  // downstream faulted section), and whether it has ended.
  float drain_from_mm = -std::numeric_limits<float>::infinity();
  bool drain_over = false;
  std::int64_t last_time_ns = 0;
  bool first_scan = true;
  bool start_requested = false;
  bool stop_requested = false;
  bool ack_requested = false;
};

LineController::LineController(const LineConfig& config) : impl_(std::make_unique<Impl>(config)) {
  impl_->reset();
}
LineController::~LineController() = default;

void LineController::reset() { impl_->reset(); }
void LineController::update(const InputImage& in, OutputImage& out) { impl_->update(in, out); }
void LineController::request_start() { impl_->start_requested = true; }
void LineController::request_stop() { impl_->stop_requested = true; }
void LineController::acknowledge_faults() { impl_->ack_requested = true; }
LineState LineController::state() const { return impl_->state; }
std::uint32_t LineController::active_faults() const {
  return impl_->faults | impl_->latched_faults;
}
const ControllerCounters& LineController::counters() const { return impl_->counters; }
std::size_t LineController::tracked_count() const { return impl_->tracker.active_count(); }
RecordRing& LineController::closed_records() { return impl_->records; }
EventRing& LineController::events() { return impl_->events; }
std::uint64_t LineController::records_dropped() const { return impl_->records.dropped(); }
std::uint64_t LineController::events_dropped() const { return impl_->events.dropped(); }

std::size_t LineController::tracked_items(std::span<TrackedItemView> out) const {
  std::size_t count = 0;
  for (const Item& item : impl_->tracker.items()) {
    if (!item.active || count == out.size()) continue;
    TrackedItemView& view = out[count++];
    view =
        TrackedItemView{item.id,          item.s_mm,           item.y_mm,          item.angle_rad,
                        item.angle_known, item.reject_pending, item.multilane_unit};
    view.hand = item.hand;
    view.side = item.side;
    view.classified = item.classified;
    view.flip_plate1 = item.flip1;
    view.flip_plate2 = item.flip2;
    view.orienting_done = item.orienting_done;
    view.reject_reason = item.reject_reason;
  }
  return count;
}

void LineController::close_all_in_transit(std::int64_t time_ns, LostReason reason) {
  for (Item& item : impl_->tracker.items()) {
    if (item.active) {
      impl_->tracker.close(item, time_ns, Outcome::kLost, reason, impl_->records, impl_->events);
    }
  }
  impl_->refresh_counters();
}

}  // namespace fl
