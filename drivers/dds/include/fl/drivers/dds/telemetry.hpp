// The controller's telemetry for the plant beyond the operator screen (MES, dashboards,
// audits): every closed fillet record on fl/line/ledger, every fault raised or cleared on
// fl/line/faults, and once a period the KPIs (fl/line/kpis) and the scan timing
// (fl/line/cycle) from the line status snapshots. Runs on
// a non-real-time thread (the one that drains the controller's ledger ring); DDS allocates
// and locks inside.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "fillet_line.h"
#include "fl/controller/ledger.hpp"
#include "fl/controller/line_status.hpp"
#include "fl/drivers/dds/entity.hpp"

namespace fl::drivers::dds {

void to_idl(const FilletRecord& record, fl_FilletLedgerRecord& sample) noexcept;
// nullopt when an enumeration is out of range (a sample from a newer or broken writer).
std::optional<FilletRecord> from_idl(const fl_FilletLedgerRecord& sample) noexcept;
void to_idl(const LineStatus& status, fl_LineKpis& sample) noexcept;
void to_idl(const LineStatus& status, fl_CycleStatistics& sample) noexcept;

// A fault raised or cleared, wherever it was detected (the IDL's FaultReport without the
// number, which the publisher stamps).
enum class FaultOrigin : std::uint8_t { kLine, kRuntime, kCanNode, kCanBus };
struct FaultReport {
  std::int64_t time_ns = 0;
  FaultOrigin origin = FaultOrigin::kLine;
  bool active = true;
  std::uint32_t code = 0;
  std::uint8_t source = 0;
  std::string text;  // cut to the IDL's 96 characters on the wire
};
// The report of a controller event: kFaultRaised and kFaultCleared give one ("camera silent:
// camera position"), every other event nullopt.
std::optional<FaultReport> fault_report(const Event& event);
void to_idl(const FaultReport& report, std::uint64_t number, fl_FaultReport& sample) noexcept;

struct TelemetryCounters {
  std::uint64_t records_published = 0;
  std::uint64_t faults_published = 0;
  std::uint64_t kpis_published = 0;
  std::uint64_t write_failures = 0;  // DDS refused a write (logged once per kind)
};

class DdsTelemetryPublisher {
 public:
  // `period_ns`: KPIs and cycle statistics at most this often, by the snapshots' time.
  explicit DdsTelemetryPublisher(const Participant& participant,
                                 std::int64_t period_ns = 1'000'000'000);

  // One closed record. A failed write is counted and logged, never thrown: the ledger CSV
  // beside it stays the record of truth.
  void publish(const FilletRecord& record);
  // One fault report, numbered in publication order from 1. Failures as for records.
  void publish(const FaultReport& report);
  // Publishes KPIs and cycle statistics from `status` when a period has passed since the
  // last publication (or none was made); returns whether it did.
  bool offer(const LineStatus& status);

  [[nodiscard]] const TelemetryCounters& counters() const noexcept { return counters_; }
  [[nodiscard]] std::uint32_t matched_ledger_readers() const {
    return ledger_writer_.matched_readers();
  }
  [[nodiscard]] std::uint32_t matched_fault_readers() const {
    return faults_writer_.matched_readers();
  }

 private:
  void count_failure(dds_return_t result, const char* topic);

  std::int64_t period_ns_;
  Topic ledger_topic_;
  Topic kpis_topic_;
  Topic cycle_topic_;
  Topic faults_topic_;
  Writer ledger_writer_;
  Writer kpis_writer_;
  Writer cycle_writer_;
  Writer faults_writer_;
  std::uint64_t faults_numbered_ = 0;
  std::optional<std::int64_t> last_offer_ns_;
  TelemetryCounters counters_;
};

}  // namespace fl::drivers::dds
