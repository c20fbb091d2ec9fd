// The QoS of each topic, chosen on purpose (docs/dds.md explains each choice). Readers and
// writers of one topic call the same function, so that what a writer offers always
// satisfies what a reader requests: a reader's deadline and liveliness lease must be at
// least the writer's, reliability at most the writer's, durability at most the writer's.
#pragma once

#include <cstdint>

#include "fl/drivers/dds/entity.hpp"

namespace fl::drivers::dds {

inline constexpr const char* kEstimatesTopic = "fl/camera/estimates";
inline constexpr const char* kCommandTopic = "fl/line/command";
inline constexpr const char* kStatusTopic = "fl/line/status";
inline constexpr const char* kFeedbackTopic = "fl/drive/feedback";
inline constexpr const char* kSensorsTopic = "fl/line/sensors";
inline constexpr const char* kLedgerTopic = "fl/line/ledger";
inline constexpr const char* kKpisTopic = "fl/line/kpis";
inline constexpr const char* kCycleTopic = "fl/line/cycle";
inline constexpr const char* kFaultsTopic = "fl/line/faults";

// A silent camera is noticed after this many of its frame periods: one lost frame is
// normal jitter, three in a row is a camera that stopped (and still well inside the
// controller's own silence limit of five periods, controller/src/logic/line_controller.cpp).
inline constexpr std::int64_t kEstimateDeadlinePeriods = 3;
inline constexpr std::int64_t kEstimateLeasePeriods = 3;
// A command stream is late after three scans: the same count the runtime faults on
// (RuntimeOptions::overrun_fault_consecutive).
inline constexpr std::int64_t kCommandDeadlineScans = 3;
// Liveliness lease of the command writer: five scans, so one late PMD message is no loss.
inline constexpr std::int64_t kCommandLeaseScans = 5;
// The slowest camera of config/line.yaml delivers every 40 ms.
inline constexpr std::int64_t kSlowestCameraPeriodNs = 40'000'000;
inline constexpr std::int64_t kScanPeriodNs = 10'000'000;

// Estimates: reliable keep-last 1 per camera (instance), volatile, deadline and automatic
// liveliness of kEstimate*Periods camera periods. A writer uses its own camera's period, a
// reader the slowest camera's (a reader's deadline must not be shorter than a writer's).
Qos estimates_qos(std::int64_t camera_period_ns = kSlowestCameraPeriodNs);
// Commands: reliable keep-last 1, volatile, deadline kCommandDeadlineScans scans,
// automatic liveliness with a kCommandLeaseScans-scan lease.
Qos command_qos(std::int64_t scan_period_ns = kScanPeriodNs);
// Status: reliable keep-last 1, transient-local: a late subscriber (HMI) gets the current
// state at once.
Qos status_qos();
// Sensors (the line's I/O to the controller, one sample per scan): the same shape as commands
// and for the same reasons: reliable keep-last 1 (a lost sample is repaired while it is the
// newest), deadline kCommandDeadlineScans scans and a kCommandLeaseScans-scan lease so that
// the controller can tell a silent I/O side from a quiet one.
Qos sensors_qos(std::int64_t scan_period_ns = kScanPeriodNs);
// Drive feedback telemetry: best-effort keep-last 1 per drive; the next sample supersedes.
// Also the cycle statistics (fl/line/cycle), for the same reason.
Qos feedback_qos();
// The fillet ledger: reliable, transient-local, keep-last LEDGER_HISTORY (the IDL's): every
// closed fillet reaches a live subscriber, and one that joins late (an MES restarted) still
// gets the last LEDGER_HISTORY records. Not keep-all: a stuck subscriber must not make the
// controller's telemetry thread block.
Qos ledger_qos();
// KPIs: as the status (reliable keep-last 1, transient-local): a late dashboard gets the
// current totals at once.
Qos kpis_qos();
// Fault reports: as the ledger with FAULT_HISTORY (the IDL's) kept: each report reaches a
// live subscriber in order, a late one gets the recent history, and none blocks the writer.
Qos faults_qos();

}  // namespace fl::drivers::dds
