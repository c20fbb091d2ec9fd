// The controller's telemetry topics with real Cyclone participants on loopback: ledger
// records arrive field for field, a subscriber that joins late still gets the history the
// QoS promises, KPIs and cycle statistics follow the snapshots at the publication period,
// and a corrupt ledger sample is refused rather than guessed.
#include "fl/drivers/dds/telemetry.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "dds_test_support.hpp"
#include "fl/controller/line_controller.hpp"
#include "fl/drivers/dds/qos.hpp"

namespace fl::drivers::dds {
namespace {

using namespace std::chrono_literals;
using test::wait_until;

constexpr auto kMatchTimeout = 5s;  // discovery on loopback takes ms; this guards loaded CI

// Record i: every field a distinct function of i, so a swapped or dropped field shows.
FilletRecord make_record(std::uint32_t i) {
  FilletRecord record;
  record.id = 1000 + i;
  record.created_ns = 1'000'000'000LL * i;
  record.closed_ns = record.created_ns + 2'500'000'000LL;
  record.outcome = static_cast<Outcome>(i % kOutcomeCount);
  record.lost_reason = i % kOutcomeCount == static_cast<std::uint32_t>(Outcome::kLost)
                           ? LostReason::kNotSeenByCamera
                           : LostReason::kNone;
  record.hand = i % 2 == 0 ? Hand::kLeft : Hand::kRight;
  record.side_seen = i % 3 == 0 ? SideUp::kBone : SideUp::kSkin;
  record.singulated = i % 4 != 0;
  record.flip_plate1 = i % 2 == 1;
  record.flip_plate2 = i % 3 == 1;
  record.multilane_unit = static_cast<std::int8_t>(static_cast<int>(i % 3) - 1);
  record.angle_at_camera1_rad = 0.01F * static_cast<float>(i);
  record.final_angle_rad = -0.02F * static_cast<float>(i);
  record.final_y_mm = 1.5F * static_cast<float>(i);
  return record;
}

void expect_same(const FilletRecord& a, const FilletRecord& b) {
  EXPECT_EQ(a.id, b.id);
  EXPECT_EQ(a.created_ns, b.created_ns);
  EXPECT_EQ(a.closed_ns, b.closed_ns);
  EXPECT_EQ(a.outcome, b.outcome);
  EXPECT_EQ(a.lost_reason, b.lost_reason);
  EXPECT_EQ(a.hand, b.hand);
  EXPECT_EQ(a.side_seen, b.side_seen);
  EXPECT_EQ(a.singulated, b.singulated);
  EXPECT_EQ(a.flip_plate1, b.flip_plate1);
  EXPECT_EQ(a.flip_plate2, b.flip_plate2);
  EXPECT_EQ(a.multilane_unit, b.multilane_unit);
  EXPECT_EQ(a.angle_at_camera1_rad, b.angle_at_camera1_rad);
  EXPECT_EQ(a.final_angle_rad, b.final_angle_rad);
  EXPECT_EQ(a.final_y_mm, b.final_y_mm);
}

// Takes every available sample of type T from `reader`.
template <class T>
std::vector<T> take_all(const Reader& reader) {
  std::vector<T> taken;
  T sample{};
  void* buffer = &sample;
  dds_sample_info_t info{};
  while (dds_take(reader.get(), &buffer, &info, 1, 1) > 0) {
    if (info.valid_data) taken.push_back(sample);
  }
  return taken;
}

TEST(DdsTelemetry, LedgerRecordsArriveFieldForField) {
  Participant controller(43);
  Participant mes(43);
  DdsTelemetryPublisher publisher(controller);
  const Topic topic(mes, fl_FilletLedgerRecord_desc, kLedgerTopic);
  const Reader reader(mes, topic, ledger_qos().get());
  ASSERT_TRUE(wait_until([&] { return publisher.matched_ledger_readers() == 1; }, kMatchTimeout));
  // 18 records: every outcome twice (9 outcomes).
  constexpr std::uint32_t kRecords = 18;
  for (std::uint32_t i = 0; i < kRecords; ++i) publisher.publish(make_record(i));
  std::vector<fl_FilletLedgerRecord> received;
  ASSERT_TRUE(wait_until(
      [&] {
        for (const auto& sample : take_all<fl_FilletLedgerRecord>(reader)) {
          received.push_back(sample);
        }
        return received.size() == kRecords;
      },
      2s));
  for (std::uint32_t i = 0; i < kRecords; ++i) {
    const std::optional<FilletRecord> record = from_idl(received[i]);
    ASSERT_TRUE(record) << "record " << i;
    expect_same(*record, make_record(i));
  }
  EXPECT_EQ(publisher.counters().records_published, kRecords);
  EXPECT_EQ(publisher.counters().write_failures, 0U);
}

TEST(DdsTelemetry, ALateSubscriberGetsTheKeptHistory) {
  Participant controller(44);
  DdsTelemetryPublisher publisher(controller);
  // Written before anyone listens: LEDGER_HISTORY + 10 records, so the oldest 10 fall out.
  const std::uint32_t written = fl_LEDGER_HISTORY + 10;
  for (std::uint32_t i = 0; i < written; ++i) publisher.publish(make_record(i));
  Participant mes(44);
  const Topic topic(mes, fl_FilletLedgerRecord_desc, kLedgerTopic);
  const Reader reader(mes, topic, ledger_qos().get());
  std::vector<fl_FilletLedgerRecord> received;
  ASSERT_TRUE(wait_until(
      [&] {
        for (const auto& sample : take_all<fl_FilletLedgerRecord>(reader)) {
          received.push_back(sample);
        }
        return received.size() >= fl_LEDGER_HISTORY;
      },
      kMatchTimeout));
  ASSERT_EQ(received.size(), fl_LEDGER_HISTORY);
  EXPECT_EQ(received.front().id, make_record(10).id);
  EXPECT_EQ(received.back().id, make_record(written - 1).id);
}

TEST(DdsTelemetry, KpisAndCycleStatisticsFollowTheSnapshotsOncePerPeriod) {
  Participant controller(45);
  Participant dashboard(45);
  DdsTelemetryPublisher publisher(controller);
  const Topic kpis_topic(dashboard, fl_LineKpis_desc, kKpisTopic);
  const Topic cycle_topic(dashboard, fl_CycleStatistics_desc, kCycleTopic);
  const Reader kpis_reader(dashboard, kpis_topic, kpis_qos().get());
  const Reader cycle_reader(dashboard, cycle_topic, feedback_qos().get());
  ASSERT_TRUE(wait_until([&] { return kpis_reader.matched_writers() == 1; }, kMatchTimeout));
  ASSERT_TRUE(wait_until([&] { return cycle_reader.matched_writers() == 1; }, kMatchTimeout));
  LineStatus status;
  status.counters.items_created = 120;
  status.counters.items_closed = 110;
  status.counters.outcomes[static_cast<std::size_t>(Outcome::kPlaced)] = 100;
  status.counters.outcomes[static_cast<std::size_t>(Outcome::kLost)] = 1;
  status.records_dropped = 0;
  status.timing.period_ns = 10'000'000;
  status.timing.scans = 6000;
  status.timing.max_wakeup_latency_ns = 143'000;
  // Snapshots every scan for 2.5 s at the default 1 s period: published at 0, 1 and 2 s.
  int offered = 0;
  for (int scan = 0; scan <= 250; ++scan) {
    status.time_ns = 10'000'000LL * scan;
    if (publisher.offer(status)) ++offered;
  }
  EXPECT_EQ(offered, 3);
  EXPECT_EQ(publisher.counters().kpis_published, 3U);
  // Keep-last 1: the reader holds the newest, the 2 s snapshot.
  std::vector<fl_LineKpis> kpis;
  ASSERT_TRUE(wait_until(
      [&] {
        for (const auto& sample : take_all<fl_LineKpis>(kpis_reader)) kpis.push_back(sample);
        return !kpis.empty() && kpis.back().time_ns == 2'000'000'000;
      },
      2s));
  EXPECT_EQ(kpis.back().items_created, 120U);
  EXPECT_EQ(kpis.back().items_closed, 110U);
  EXPECT_EQ(kpis.back().outcomes[static_cast<std::size_t>(Outcome::kPlaced)], 100U);
  EXPECT_EQ(kpis.back().outcomes[static_cast<std::size_t>(Outcome::kLost)], 1U);
  std::vector<fl_CycleStatistics> cycle;
  ASSERT_TRUE(wait_until(
      [&] {
        for (const auto& sample : take_all<fl_CycleStatistics>(cycle_reader)) {
          cycle.push_back(sample);
        }
        return !cycle.empty() && cycle.back().time_ns == 2'000'000'000;
      },
      2s));
  EXPECT_EQ(cycle.back().period_ns, 10'000'000);
  EXPECT_EQ(cycle.back().scans, 6000U);
  EXPECT_EQ(cycle.back().max_wakeup_latency_ns, 143'000);
}

TEST(DdsTelemetry, FaultReportsArriveNumberedAndALateSubscriberGetsTheHistory) {
  Participant controller(38);
  DdsTelemetryPublisher publisher(controller);
  // FAULT_HISTORY + 6 reports before anyone listens: the oldest 6 fall out of the history.
  const std::uint32_t written = fl_FAULT_HISTORY + 6;
  for (std::uint32_t i = 0; i < written; ++i) {
    FaultReport report;
    report.time_ns = 1'000'000LL * i;
    report.origin = i % 2 == 0 ? FaultOrigin::kCanNode : FaultOrigin::kLine;
    report.active = i % 3 != 0;
    report.code = 0x2310U + i;
    report.source = static_cast<std::uint8_t>(i % 16);
    report.text = "report " + std::to_string(i);
    if (i == written - 1) report.text = std::string(200, 'x');  // longer than the wire's 96
    publisher.publish(report);
  }
  EXPECT_EQ(publisher.counters().faults_published, written);
  Participant hmi(38);
  const Topic topic(hmi, fl_FaultReport_desc, kFaultsTopic);
  const Reader reader(hmi, topic, faults_qos().get());
  std::vector<fl_FaultReport> received;
  ASSERT_TRUE(wait_until(
      [&] {
        for (const auto& sample : take_all<fl_FaultReport>(reader)) received.push_back(sample);
        return received.size() >= fl_FAULT_HISTORY;
      },
      kMatchTimeout));
  ASSERT_EQ(received.size(), fl_FAULT_HISTORY);
  for (std::size_t k = 0; k < received.size(); ++k) {
    const std::uint32_t i = 6 + static_cast<std::uint32_t>(k);
    const fl_FaultReport& sample = received[k];
    EXPECT_EQ(sample.number, i + 1U);  // numbered from 1 in publication order
    EXPECT_EQ(sample.time_ns, 1'000'000LL * i);
    EXPECT_EQ(sample.origin, i % 2 == 0 ? fl_FAULT_ORIGIN_CAN_NODE : fl_FAULT_ORIGIN_LINE);
    EXPECT_EQ(sample.active, i % 3 != 0);
    EXPECT_EQ(sample.code, 0x2310U + i);
    EXPECT_EQ(sample.source, i % 16);
    if (i + 1 < written) {
      EXPECT_STREQ(sample.text, ("report " + std::to_string(i)).c_str());
    }
  }
  // Cut to the bound, still terminated.
  EXPECT_EQ(std::string(received.back().text), std::string(96, 'x'));
}

TEST(DdsTelemetry, OnlyFaultEventsOfTheControllerBecomeReportsNamingTheirSource) {
  const Event silent{5'000'000'000, EventCode::kFaultRaised, 0,
                     static_cast<std::uint8_t>(FaultCode::kCameraSilent),
                     static_cast<float>(CameraId::kPosition)};
  const std::optional<FaultReport> raised = fault_report(silent);
  ASSERT_TRUE(raised);
  EXPECT_EQ(raised->origin, FaultOrigin::kLine);
  EXPECT_TRUE(raised->active);
  EXPECT_EQ(raised->code, static_cast<std::uint32_t>(FaultCode::kCameraSilent));
  EXPECT_EQ(raised->source, static_cast<std::uint8_t>(CameraId::kPosition));
  EXPECT_EQ(raised->time_ns, 5'000'000'000);
  EXPECT_NE(raised->text.find(to_string(CameraId::kPosition)), std::string::npos) << raised->text;

  const Event drive_back{6'000'000'000, EventCode::kFaultCleared, 0,
                         static_cast<std::uint8_t>(FaultCode::kDriveFault),
                         static_cast<float>(DriveId::kTakt)};
  const std::optional<FaultReport> cleared = fault_report(drive_back);
  ASSERT_TRUE(cleared);
  EXPECT_FALSE(cleared->active);
  EXPECT_NE(cleared->text.find(to_string(DriveId::kTakt)), std::string::npos) << cleared->text;

  // A broken index is no index: source 0, and the text names no camera.
  Event broken = silent;
  broken.value = std::numeric_limits<float>::quiet_NaN();
  ASSERT_TRUE(fault_report(broken));
  EXPECT_EQ(fault_report(broken)->source, 0);
  EXPECT_EQ(fault_report(broken)->text.find(": camera"), std::string::npos);

  // Not a fault change: no report.
  EXPECT_FALSE(fault_report(Event{0, EventCode::kItemCreated, 7, 0, 0.0F}));
  EXPECT_FALSE(fault_report(Event{0, EventCode::kCameraSilent, 0, 1, 0.0F}));
}

TEST(DdsTelemetry, ACorruptLedgerSampleIsRefused) {
  fl_FilletLedgerRecord good{};
  to_idl(make_record(3), good);
  ASSERT_TRUE(from_idl(good));
  auto broken = good;
  broken.outcome = static_cast<std::uint8_t>(kOutcomeCount);  // one past the last outcome
  EXPECT_FALSE(from_idl(broken));
  broken = good;
  broken.lost_reason = 200;  // no such reason
  EXPECT_FALSE(from_idl(broken));
  broken = good;
  // The IDL's enums have three enumerators; a peer may send any 32-bit value.
  const int no_such_hand = 7;
  std::memcpy(&broken.hand, &no_such_hand, sizeof no_such_hand);
  EXPECT_FALSE(from_idl(broken));
  broken = good;
  const int no_such_side = -1;
  std::memcpy(&broken.side_seen, &no_such_side, sizeof no_such_side);
  EXPECT_FALSE(from_idl(broken));
  broken = good;
  broken.multilane_unit = 2;  // the line has units 0 and 1
  EXPECT_FALSE(from_idl(broken));
}

}  // namespace
}  // namespace fl::drivers::dds
