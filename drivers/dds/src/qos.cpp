#include "fl/drivers/dds/qos.hpp"

#include "fillet_line.h"

namespace fl::drivers::dds {

Qos estimates_qos(std::int64_t camera_period_ns) {
  Qos qos = make_qos();
  // Reliable but keep-last 1: a frame lost on the wire is repaired only while it is still
  // the newest of its camera, and a writer never blocks on a slow reader.
  dds_qset_reliability(qos.get(), DDS_RELIABILITY_RELIABLE, DDS_MSECS(10));
  dds_qset_history(qos.get(), DDS_HISTORY_KEEP_LAST, 1);
  // An old frame is worthless to a late joiner: the tracker would refuse it as stale.
  dds_qset_durability(qos.get(), DDS_DURABILITY_VOLATILE);
  dds_qset_deadline(qos.get(), kEstimateDeadlinePeriods * camera_period_ns);
  // Automatic: Cyclone asserts it while the process runs, so a killed or hung camera node
  // (not a camera that merely has nothing to report) is what loses liveliness.
  dds_qset_liveliness(qos.get(), DDS_LIVELINESS_AUTOMATIC,
                      kEstimateLeasePeriods * camera_period_ns);
  // The frame's exposure time is in the sample; source order keeps a late repair from
  // overtaking a newer frame of the same camera.
  dds_qset_destination_order(qos.get(), DDS_DESTINATIONORDER_BY_SOURCE_TIMESTAMP);
  return qos;
}

Qos command_qos(std::int64_t scan_period_ns) {
  Qos qos = make_qos();
  // Losing a command is not harmless (an actuator edge), so reliable; keep-last 1 because
  // only the newest command is worth repairing.
  dds_qset_reliability(qos.get(), DDS_RELIABILITY_RELIABLE, DDS_MSECS(10));
  dds_qset_history(qos.get(), DDS_HISTORY_KEEP_LAST, 1);
  dds_qset_durability(qos.get(), DDS_DURABILITY_VOLATILE);
  dds_qset_deadline(qos.get(), kCommandDeadlineScans * scan_period_ns);
  dds_qset_liveliness(qos.get(), DDS_LIVELINESS_AUTOMATIC, kCommandLeaseScans * scan_period_ns);
  return qos;
}

Qos sensors_qos(std::int64_t scan_period_ns) { return command_qos(scan_period_ns); }

Qos status_qos() {
  Qos qos = make_qos();
  dds_qset_reliability(qos.get(), DDS_RELIABILITY_RELIABLE, DDS_MSECS(100));
  dds_qset_history(qos.get(), DDS_HISTORY_KEEP_LAST, 1);
  dds_qset_durability(qos.get(), DDS_DURABILITY_TRANSIENT_LOCAL);
  return qos;
}

namespace {

// Reliable, transient-local, the last `history` samples kept for late subscribers.
Qos kept_history_qos(std::int32_t history) {
  Qos qos = make_qos();
  dds_qset_reliability(qos.get(), DDS_RELIABILITY_RELIABLE, DDS_MSECS(100));
  dds_qset_history(qos.get(), DDS_HISTORY_KEEP_LAST, history);
  dds_qset_durability(qos.get(), DDS_DURABILITY_TRANSIENT_LOCAL);
  dds_qset_durability_service(qos.get(), 0, DDS_HISTORY_KEEP_LAST, history, DDS_LENGTH_UNLIMITED,
                              DDS_LENGTH_UNLIMITED, DDS_LENGTH_UNLIMITED);
  return qos;
}

}  // namespace

Qos ledger_qos() { return kept_history_qos(fl_LEDGER_HISTORY); }

Qos faults_qos() { return kept_history_qos(fl_FAULT_HISTORY); }

Qos kpis_qos() { return status_qos(); }

Qos feedback_qos() {
  Qos qos = make_qos();
  dds_qset_reliability(qos.get(), DDS_RELIABILITY_BEST_EFFORT, 0);
  dds_qset_history(qos.get(), DDS_HISTORY_KEEP_LAST, 1);
  dds_qset_durability(qos.get(), DDS_DURABILITY_VOLATILE);
  return qos;
}

}  // namespace fl::drivers::dds
