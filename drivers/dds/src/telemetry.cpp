#include "fl/drivers/dds/telemetry.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <type_traits>

#include "fl/controller/line_controller.hpp"
#include "fl/drivers/dds/qos.hpp"

namespace fl::drivers::dds {
namespace {

static_assert(fl_OUTCOME_COUNT == kOutcomeCount, "the IDL's OUTCOME_COUNT follows fl::Outcome");
// The last enumerator of fl::LostReason; from_idl refuses anything beyond.
constexpr auto kLastLostReason = static_cast<std::uint8_t>(LostReason::kRunEnded);

}  // namespace

void to_idl(const FilletRecord& record, fl_FilletLedgerRecord& sample) noexcept {
  sample.id = record.id;
  sample.created_ns = record.created_ns;
  sample.closed_ns = record.closed_ns;
  sample.outcome = static_cast<std::uint8_t>(record.outcome);
  sample.lost_reason = static_cast<std::uint8_t>(record.lost_reason);
  sample.hand = static_cast<fl_Hand>(record.hand);
  sample.side_seen = static_cast<fl_SideUp>(record.side_seen);
  sample.singulated = record.singulated;
  sample.flip_plate1 = record.flip_plate1;
  sample.flip_plate2 = record.flip_plate2;
  // A small signed number (-1: none), not a character.
  sample.multilane_unit = record.multilane_unit;  // NOLINT(bugprone-signed-char-misuse)
  sample.angle_at_camera1_rad = record.angle_at_camera1_rad;
  sample.final_angle_rad = record.final_angle_rad;
  sample.final_y_mm = record.final_y_mm;
}

std::optional<FilletRecord> from_idl(const fl_FilletLedgerRecord& sample) noexcept {
  // The enums read as their underlying integers: loading an enum object that holds no
  // enumerator's value is undefined behaviour (as in convert.cpp's validate()).
  std::underlying_type_t<fl_Hand> hand = 0;
  std::underlying_type_t<fl_SideUp> side = 0;
  std::memcpy(&hand, &sample.hand, sizeof hand);
  std::memcpy(&side, &sample.side_seen, sizeof side);
  if (sample.outcome >= kOutcomeCount || sample.lost_reason > kLastLostReason ||
      hand < fl_HAND_UNKNOWN || hand > fl_HAND_RIGHT || side < fl_SIDE_UNKNOWN ||
      side > fl_SIDE_BONE || sample.multilane_unit < -1 || sample.multilane_unit > 1) {
    return std::nullopt;
  }
  FilletRecord record;
  record.id = sample.id;
  record.created_ns = sample.created_ns;
  record.closed_ns = sample.closed_ns;
  record.outcome = static_cast<Outcome>(sample.outcome);
  record.lost_reason = static_cast<LostReason>(sample.lost_reason);
  record.hand = static_cast<Hand>(sample.hand);
  record.side_seen = static_cast<SideUp>(sample.side_seen);
  record.singulated = sample.singulated;
  record.flip_plate1 = sample.flip_plate1;
  record.flip_plate2 = sample.flip_plate2;
  record.multilane_unit = static_cast<std::int8_t>(sample.multilane_unit);
  record.angle_at_camera1_rad = sample.angle_at_camera1_rad;
  record.final_angle_rad = sample.final_angle_rad;
  record.final_y_mm = sample.final_y_mm;
  return record;
}

void to_idl(const LineStatus& status, fl_LineKpis& sample) noexcept {
  const ControllerCounters& counters = status.counters;
  sample.time_ns = status.time_ns;
  sample.items_created = counters.items_created;
  sample.items_adopted = counters.items_adopted;
  sample.items_closed = counters.items_closed;
  sample.takt_strokes = counters.takt_strokes;
  sample.reject_reversals = counters.reject_reversals;
  sample.flip_conflicts = counters.flip_conflicts;
  sample.estimates_rejected = counters.estimates_rejected;
  sample.frames_processed = counters.frames_processed;
  for (std::size_t o = 0; o < kOutcomeCount; ++o) sample.outcomes[o] = counters.outcomes[o];
  sample.records_dropped = status.records_dropped;
  sample.events_dropped = status.events_dropped;
}

std::optional<FaultReport> fault_report(const Event& event) {
  if (event.code != EventCode::kFaultRaised && event.code != EventCode::kFaultCleared) {
    return std::nullopt;
  }
  FaultReport report;
  report.time_ns = event.time_ns;
  report.origin = FaultOrigin::kLine;
  report.active = event.code == EventCode::kFaultRaised;
  report.code = event.source;  // the FaultCode
  const auto code = static_cast<FaultCode>(event.source);
  // The line controller puts the camera or drive index into the event's value; one that is
  // no index names nothing rather than camera 0.
  const float index = event.value;
  const bool indexed = std::isfinite(index) && index >= 0.0F && index < 256.0F;
  report.source = indexed ? static_cast<std::uint8_t>(index) : 0;
  report.text = to_string(code);
  if (indexed && (code == FaultCode::kCameraSilent || code == FaultCode::kEstimateFlood) &&
      report.source < kCameraCount) {
    report.text += ": camera ";
    report.text += to_string(static_cast<CameraId>(report.source));
  } else if (indexed && code == FaultCode::kDriveFault && report.source < kDriveCount) {
    report.text += ": drive ";
    report.text += to_string(static_cast<DriveId>(report.source));
  }
  report.text += report.active ? " (raised)" : " (cleared)";
  return report;
}

void to_idl(const FaultReport& report, std::uint64_t number, fl_FaultReport& sample) noexcept {
  sample.time_ns = report.time_ns;
  sample.number = number;
  sample.origin = static_cast<fl_FaultOrigin>(report.origin);
  sample.active = report.active;
  sample.code = report.code;
  sample.source = report.source;
  const std::size_t length = std::min(report.text.size(), sizeof sample.text - 1);
  std::memcpy(sample.text, report.text.data(), length);
  sample.text[length] = '\0';
}

void to_idl(const LineStatus& status, fl_CycleStatistics& sample) noexcept {
  const ScanTimingStatus& timing = status.timing;
  sample.time_ns = status.time_ns;
  sample.period_ns = timing.period_ns;
  sample.scans = timing.scans;
  sample.overruns = timing.overruns;
  sample.last_wakeup_latency_ns = timing.last_wakeup_latency_ns;
  sample.last_compute_ns = timing.last_compute_ns;
  sample.window_max_wakeup_latency_ns = timing.window_max_wakeup_latency_ns;
  sample.window_max_compute_ns = timing.window_max_compute_ns;
  sample.max_wakeup_latency_ns = timing.max_wakeup_latency_ns;
  sample.max_compute_ns = timing.max_compute_ns;
}

DdsTelemetryPublisher::DdsTelemetryPublisher(const Participant& participant, std::int64_t period_ns)
    : period_ns_(period_ns),
      ledger_topic_(participant, fl_FilletLedgerRecord_desc, kLedgerTopic),
      kpis_topic_(participant, fl_LineKpis_desc, kKpisTopic),
      cycle_topic_(participant, fl_CycleStatistics_desc, kCycleTopic),
      faults_topic_(participant, fl_FaultReport_desc, kFaultsTopic),
      ledger_writer_(participant, ledger_topic_, ledger_qos().get()),
      kpis_writer_(participant, kpis_topic_, kpis_qos().get()),
      cycle_writer_(participant, cycle_topic_, feedback_qos().get()),
      faults_writer_(participant, faults_topic_, faults_qos().get()) {}

void DdsTelemetryPublisher::count_failure(dds_return_t result, const char* topic) {
  if (result >= 0) return;
  if (counters_.write_failures++ == 0) {
    spdlog::warn(
        "telemetry: writing {} failed ({}); the ledger CSV and the log keep what it carried", topic,
        dds_strretcode(result));
  }
}

void DdsTelemetryPublisher::publish(const FilletRecord& record) {
  fl_FilletLedgerRecord sample{};
  to_idl(record, sample);
  const dds_return_t result = ledger_writer_.write(sample);
  count_failure(result, kLedgerTopic);
  if (result >= 0) ++counters_.records_published;
}

void DdsTelemetryPublisher::publish(const FaultReport& report) {
  fl_FaultReport sample{};
  to_idl(report, ++faults_numbered_, sample);
  const dds_return_t result = faults_writer_.write(sample);
  count_failure(result, kFaultsTopic);
  if (result >= 0) ++counters_.faults_published;
}

bool DdsTelemetryPublisher::offer(const LineStatus& status) {
  if (last_offer_ns_ && status.time_ns - *last_offer_ns_ < period_ns_) return false;
  last_offer_ns_ = status.time_ns;
  fl_LineKpis kpis{};
  to_idl(status, kpis);
  const dds_return_t kpis_result = kpis_writer_.write(kpis);
  count_failure(kpis_result, kKpisTopic);
  fl_CycleStatistics cycle{};
  to_idl(status, cycle);
  count_failure(cycle_writer_.write(cycle), kCycleTopic);
  if (kpis_result >= 0) ++counters_.kpis_published;
  return true;
}

}  // namespace fl::drivers::dds
