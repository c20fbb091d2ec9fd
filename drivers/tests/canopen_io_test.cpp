// The master (CanopenIo) against emulated CiA 402 drives and CiA 401 modules on the
// loopback bus: start-up, velocity scaling, I/O mapping, heartbeat loss and recovery, EMCY,
// malformed frames, and the real-time contract of read()/write().
#include "fl/drivers/canopen_io.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "loopback_rig.hpp"
#include "scan_thread_probe.hpp"

namespace fl::drivers {
namespace {

using canopen::NmtState;
using canopen::NodeId;
using test::all_drives;
using test::LoopbackRig;

TEST(CanopenIo, StartUpConfiguresEveryNodeAndReachesOperationEnabled) {
  LoopbackRig rig;
  const StartupReport report = rig.start(true);
  ASSERT_TRUE(report.ok) << (report.problems.empty() ? "" : report.problems.front());
  rig.io.read(rig.now_ns, rig.in);
  for (std::size_t d = 0; d < kDriveCount; ++d) {
    const auto& drive = *rig.drives[d];
    EXPECT_EQ(drive.nmt_state(), canopen::NmtState::kOperational);
    EXPECT_EQ(drive.state().state, cia402::State::kOperationEnabled);
    EXPECT_EQ(drive.state().mode, 3);  // profile velocity
    // The mapping the master wrote: RPDO1 = controlword + target velocity, on its COB-ID.
    EXPECT_EQ(drive.value(0x1600, 0), 2U);
    EXPECT_EQ(drive.value(0x1600, 2), 0x60FF0020U);
    EXPECT_EQ(drive.value(0x1400, 1), rig.config.drives[d].rpdo1_cob_id);
    EXPECT_EQ(drive.value(0x1017, 0), 50U);  // heartbeat producer from can.yaml
    // Ramps at the line's limit: takt 8 m/s^2, others 5 or 6, times 10000 units.
    EXPECT_EQ(
        drive.state().acceleration,
        static_cast<std::uint32_t>(std::lround(rig.config.drives[d].max_accel_mps2 * 10000.0)));
    EXPECT_TRUE(rig.in.drives[d].ready);
    EXPECT_FALSE(rig.in.drives[d].fault);
  }
  // NMT reset, 16 boot-ups, about 20 SDO transfers per node and three enable cycles: well
  // under the 5 s boot plus 1 s enable budget of can.yaml on the simulated clock.
  EXPECT_LT(report.duration_ns, 1'000'000'000);
}

TEST(CanopenIo, StartUpWithoutEnablePrimesTheImageWithEveryDevice) {
  // The controller's own start-up (linectl control --can) leaves the drives disabled, and the
  // first scan must still read the devices: an empty image reads an open safety chain.
  LoopbackRig rig;
  const StartupReport report = rig.start(false);
  ASSERT_TRUE(report.ok) << (report.problems.empty() ? "" : report.problems.front());
  rig.io.read(rig.now_ns, rig.in);
  EXPECT_TRUE(rig.in.estop_ok);  // the safety module's chain input, closed by the rig
  for (std::size_t d = 0; d < kDriveCount; ++d) {
    EXPECT_NE(rig.drives[d]->state().state, cia402::State::kOperationEnabled);
    EXPECT_FALSE(rig.in.drives[d].ready);
    EXPECT_FALSE(rig.in.drives[d].fault) << "drive slot " << d;
  }
}

TEST(CanopenIo, ShutDownDisablesTheDrivesThenStopsEveryNode) {
  LoopbackRig rig;
  ASSERT_TRUE(rig.start(true).ok);
  for (int i = 0; i < 10; ++i) rig.scan(all_drives(true, 0.5F));
  ASSERT_EQ(rig.drive(DriveId::kGuide).state().state, cia402::State::kOperationEnabled);
  EXPECT_TRUE(rig.io.shut_down(rig.clock));
  rig.advance(10'000'000);  // the NMT frame reaches the devices
  for (std::size_t d = 0; d < kDriveCount; ++d) {
    EXPECT_NE(rig.drives[d]->state().state, cia402::State::kOperationEnabled) << "drive " << d;
    EXPECT_EQ(rig.drives[d]->nmt_state(), canopen::NmtState::kStopped) << "drive " << d;
  }
  for (std::size_t m = 0; m < kIoModuleCount; ++m) {
    EXPECT_EQ(rig.modules[m]->nmt_state(), canopen::NmtState::kStopped) << "module " << m;
  }
}

TEST(CanopenIo, ACleanStartAndStopRaiseNoFault) {
  // The start-up resets and starts every node, the shut-down stops them: 16 boot-ups and 16
  // stopped heartbeats that the master asked for, none of them a fault for the fault topic.
  // (The NMT start shows no change: the master takes its own command as the state.)
  LoopbackRig rig;
  ASSERT_TRUE(rig.start(true).ok);
  for (int i = 0; i < 10; ++i) rig.scan(all_drives(true, 0.5F));
  ASSERT_TRUE(rig.io.shut_down(rig.clock));
  for (int i = 0; i < 10; ++i) rig.scan(OutputImage{});  // the stopped heartbeats arrive
  std::size_t events = 0;
  std::size_t nmt_changes = 0;
  std::vector<std::string> faults;
  rig.io.log_events([&](const CanopenEvent& event) {
    ++events;
    nmt_changes += event.kind == CanopenEventKind::kNmtStateChanged ? 1 : 0;
    if (fault_transition(event)) faults.push_back(describe(event));
  });
  EXPECT_EQ(nmt_changes, kDriveCount + kIoModuleCount);  // each node's stop
  EXPECT_GT(events, nmt_changes);                        // boot-ups and drive states too
  EXPECT_TRUE(faults.empty()) << faults.front();
}

TEST(CanopenIo, StartUpNamesANodeThatNeverBoots) {
  LoopbackRig rig;
  rig.drive(DriveId::kGuide).set_silent(true);
  const StartupReport report = rig.start(true);
  EXPECT_FALSE(report.ok);
  ASSERT_FALSE(report.problems.empty());
  EXPECT_NE(report.problems.front().find("node 5 (drive guide): no boot-up"), std::string::npos)
      << report.problems.front();
}

TEST(CanopenIo, VelocityCommandReachesTheDriveScaled) {
  LoopbackRig rig;
  ASSERT_TRUE(rig.start(true).ok);
  OutputImage out = all_drives(true, 0.5F);
  out.drives[index(DriveId::kReject)].speed_mps = -1.0F;  // reversing
  out.drives[index(DriveId::kOutfeed)].speed_mps = 3.0F;  // beyond the 1 m/s limit
  rig.scan(out);
  // 0.5 m/s * 10000 counts/s per m/s = 5000, applied at the SYNC after the RPDO.
  EXPECT_EQ(rig.drive(DriveId::kGuide).state().target_velocity, 5000);
  EXPECT_EQ(rig.drive(DriveId::kReject).state().target_velocity, -10000);
  EXPECT_EQ(rig.drive(DriveId::kOutfeed).state().target_velocity, 10000);  // clamped to 1 m/s
  // 0.2 s later the drives ramp at 5 m/s^2 (50000 counts/s^2): 0.5 m/s reached after 0.1 s.
  for (int i = 0; i < 20; ++i) {
    rig.scan(out);
  }
  rig.io.read(rig.now_ns, rig.in);
  EXPECT_NEAR(rig.in.drives[index(DriveId::kGuide)].speed_mps, 0.5F, 1e-4F);
  EXPECT_NEAR(rig.in.drives[index(DriveId::kReject)].speed_mps, -1.0F, 1e-4F);
  // The encoder counts the travel: 10 counts per mm of belt.
  const double travel_mm =
      static_cast<double>(rig.drive(DriveId::kGuide).state().position_actual) / 10.0;
  EXPECT_EQ(rig.in.drives[index(DriveId::kGuide)].encoder_counts,
            rig.drive(DriveId::kGuide).state().position_actual);
  // 0.21 s of commands minus the 0.1 s ramp's half: about 80 mm.
  EXPECT_NEAR(travel_mm, 80.0, 6.0);
}

TEST(CanopenIo, AccelerationIsSentOnChangeWithinTheLimit) {
  LoopbackRig rig;
  ASSERT_TRUE(rig.start(true).ok);
  OutputImage out = all_drives(true, 0.1F);
  out.drives[index(DriveId::kTakt)].accel_mps2 = 6.0F;    // a takt stroke
  out.drives[index(DriveId::kGuide)].accel_mps2 = 50.0F;  // over its 5 m/s^2 limit
  rig.scan(out);
  rig.scan(out);
  EXPECT_EQ(rig.drive(DriveId::kTakt).state().acceleration, 60000U);
  EXPECT_EQ(rig.drive(DriveId::kGuide).state().deceleration, 50000U);
}

TEST(CanopenIo, DisableStopsAtSwitchedOnAndLineFaultQuickStops) {
  LoopbackRig rig;
  ASSERT_TRUE(rig.start(true).ok);
  rig.scan(all_drives(false, 0.0F, LineState::kStopped));
  EXPECT_EQ(rig.drive(DriveId::kBulk).state().state, cia402::State::kSwitchedOn);
  rig.scan(all_drives(true, 0.0F));
  EXPECT_EQ(rig.drive(DriveId::kBulk).state().state, cia402::State::kOperationEnabled);
  rig.scan(all_drives(false, 0.0F, LineState::kFault));
  // Quick stop active at once, then Switch On Disabled once the motor stands (it stood).
  EXPECT_EQ(rig.drive(DriveId::kBulk).state().state, cia402::State::kSwitchOnDisabled);
}

TEST(CanopenIo, IoModulesMapToTheProcessImage) {
  LoopbackRig rig;
  ASSERT_TRUE(rig.start(true).ok);
  auto& infeed = rig.module(IoModuleId::kInfeed).state();
  infeed.digital_inputs = 0x01;               // DI0: laser barrier broken
  infeed.analog_inputs = {6000, 4500, 1200};  // 60 mm level, 45 mm hopper, 120 rpm
  rig.module(IoModuleId::kStations).state().digital_inputs = 0x05;       // plate 1, squeeze down
  rig.module(IoModuleId::kStations).state().analog_inputs[0] = -1250;    // -12.5 mm
  rig.module(IoModuleId::kSafety).state().digital_inputs = 0x01 | 0x02;  // E-stop ok, start
  OutputImage out = all_drives(true, 0.0F);
  out.flip_plate2_flip = true;
  out.final_reject = true;
  out.centring_shift_mm = 23.4F;
  out.hopper_opening_mm = 90.0F;
  out.leveller_speed_rpm = 120.0F;
  rig.scan(out);  // inputs sampled at this SYNC, outputs applied
  rig.scan(out);
  rig.io.read(rig.now_ns, rig.in);
  EXPECT_TRUE(rig.in.takt_beam_broken);
  EXPECT_FALSE(rig.in.leveller_overload);
  EXPECT_NEAR(rig.in.level_mm, 60.0F, 1e-3F);
  EXPECT_NEAR(rig.in.hopper_opening_mm, 45.0F, 1e-3F);
  EXPECT_NEAR(rig.in.leveller_speed_rpm, 120.0F, 1e-3F);
  EXPECT_TRUE(rig.in.flip_plate1_flipping);
  EXPECT_FALSE(rig.in.flip_plate2_flipping);
  EXPECT_TRUE(rig.in.squeeze_roller_down);
  EXPECT_NEAR(rig.in.centring_position_mm, -12.5F, 1e-3F);
  EXPECT_TRUE(rig.in.estop_ok);
  EXPECT_TRUE(rig.in.start_request);
  const auto& stations = rig.module(IoModuleId::kStations).state();
  EXPECT_EQ(stations.digital_outputs, 0x02 | 0x10);  // DO1 plate 2, DO4 air knife
  EXPECT_EQ(stations.analog_outputs[0], 2340);       // 23.4 mm / 0.01
  EXPECT_EQ(rig.module(IoModuleId::kInfeed).state().analog_outputs[0], 9000);
  EXPECT_EQ(rig.module(IoModuleId::kInfeed).state().analog_outputs[1], 1200);
  EXPECT_EQ(rig.module(IoModuleId::kSafety).state().digital_outputs, 0x01);  // running lamp
}

TEST(CanopenIo, ARegroupedMappingFromTheConfigReachesTheDevicesAndBack) {
  // Every PDO's objects in another order than canopen::layout's: the master writes this
  // mapping at start-up, and the emulated devices, which honour whatever they are given as
  // real ones do, must still see the same commands and report the same state.
  CanConfig config = test::reference_can_config();
  config.drive_pdos.rpdo1 = {{{{0x60FF, 0, 32}, {0x6040, 0, 16}}}, 2};
  config.drive_pdos.rpdo2 = {{{{0x6084, 0, 32}, {0x6083, 0, 32}}}, 2};
  config.drive_pdos.tpdo1 = {{{{0x6064, 0, 32}, {0x6041, 0, 16}}}, 2};
  config.io_pdos.tpdo1 = {{{{0x6401, 3, 16}, {0x6000, 1, 8}, {0x6401, 1, 16}, {0x6401, 2, 16}}}, 4};
  config.io_pdos.rpdo1 = {{{{0x6411, 2, 16}, {0x6411, 1, 16}, {0x6200, 1, 8}, {0x6411, 3, 16}}}, 4};
  LoopbackRig rig(config);
  ASSERT_TRUE(rig.start(true).ok);
  EXPECT_EQ(rig.drive(DriveId::kGuide).value(0x1600, 1), 0x60FF0020U);
  EXPECT_EQ(rig.drive(DriveId::kGuide).value(0x1A00, 1), 0x60640020U);
  EXPECT_EQ(rig.module(IoModuleId::kInfeed).value(0x1A00, 1), 0x64010310U);

  auto& infeed = rig.module(IoModuleId::kInfeed).state();
  infeed.digital_inputs = 0x01;               // DI0: laser barrier broken
  infeed.analog_inputs = {6000, 4500, 1200};  // 60 mm level, 45 mm hopper, 120 rpm
  OutputImage out = all_drives(true, 0.4F);
  out.drives[index(DriveId::kGuide)].accel_mps2 = 2.0F;
  out.flip_plate2_flip = true;
  out.centring_shift_mm = 23.4F;
  out.hopper_opening_mm = 90.0F;
  out.leveller_speed_rpm = 120.0F;
  for (int i = 0; i < 30; ++i) rig.scan(out);
  rig.io.read(rig.now_ns, rig.in);

  const auto& guide = rig.drive(DriveId::kGuide).state();
  EXPECT_EQ(guide.state, cia402::State::kOperationEnabled);  // the controlword arrived
  EXPECT_EQ(guide.target_velocity, 4000);                    // 0.4 m/s * 10000
  EXPECT_EQ(guide.acceleration, 20000U);                     // 2 m/s^2 * 10000
  EXPECT_TRUE(rig.in.drives[index(DriveId::kGuide)].ready);  // the statusword came back
  EXPECT_NEAR(rig.in.drives[index(DriveId::kGuide)].speed_mps, 0.4F, 1e-4F);
  EXPECT_EQ(rig.in.drives[index(DriveId::kGuide)].encoder_counts, guide.position_actual);
  EXPECT_GT(guide.position_actual, 0);
  EXPECT_TRUE(rig.in.takt_beam_broken);
  EXPECT_NEAR(rig.in.level_mm, 60.0F, 1e-3F);
  EXPECT_NEAR(rig.in.hopper_opening_mm, 45.0F, 1e-3F);
  EXPECT_NEAR(rig.in.leveller_speed_rpm, 120.0F, 1e-3F);
  const auto& stations = rig.module(IoModuleId::kStations).state();
  EXPECT_EQ(stations.digital_outputs, 0x02);    // DO1 plate 2
  EXPECT_EQ(stations.analog_outputs[0], 2340);  // 23.4 mm / 0.01
  EXPECT_EQ(infeed.analog_outputs[0], 9000);
  EXPECT_EQ(infeed.analog_outputs[1], 1200);
  EXPECT_EQ(rig.io.counters().malformed_frames, 0U);
}

// Every device of the rig with can.yaml's mappings built in (read-only mapping objects).
void build_in_mappings(LoopbackRig& rig) {
  const DrivePdoMappings& drive = rig.config.drive_pdos;
  for (auto* device : rig.drives) {
    device->fix_mapping(0x1600, drive.rpdo1);
    device->fix_mapping(0x1601, drive.rpdo2);
    device->fix_mapping(0x1A00, drive.tpdo1);
    device->fix_mapping(0x1A01, drive.tpdo2);
  }
  for (auto* device : rig.modules) {
    device->fix_mapping(0x1600, rig.config.io_pdos.rpdo1);
    device->fix_mapping(0x1A00, rig.config.io_pdos.tpdo1);
  }
}

TEST(CanopenIo, BuiltInMappingsAreReadBackAndCheckedInsteadOfWritten) {
  // Written, as by default: the devices refuse, and the start-up says which and why.
  {
    LoopbackRig rig;
    build_in_mappings(rig);
    const StartupReport report = rig.start(true);
    ASSERT_FALSE(report.ok);
    ASSERT_FALSE(report.problems.empty());
    EXPECT_NE(report.problems.front().find("SDO write 0x1600:0x00"), std::string::npos)
        << report.problems.front();
    EXPECT_NE(report.problems.front().find("read only"), std::string::npos)
        << report.problems.front();
  }
  CanConfig built_in = test::reference_can_config();
  built_in.write_pdo_mappings = false;
  // Told they are built in: read back, found equal, and the line runs on them.
  {
    LoopbackRig rig(built_in);
    build_in_mappings(rig);
    const StartupReport report = rig.start(true);
    ASSERT_TRUE(report.ok) << (report.problems.empty() ? "" : report.problems.front());
    for (int i = 0; i < 3; ++i) rig.scan(all_drives(true, 0.4F));
    EXPECT_EQ(rig.drive(DriveId::kGuide).state().target_velocity, 4000);  // 0.4 m/s * 10000
    rig.io.read(rig.now_ns, rig.in);
    EXPECT_TRUE(rig.in.drives[index(DriveId::kGuide)].ready);
  }
  // One drive built with another order than can.yaml's: named with both, and not started.
  {
    LoopbackRig rig(built_in);
    build_in_mappings(rig);
    rig.drive(DriveId::kGuide).fix_mapping(0x1A00, {{{{0x6064, 0, 32}, {0x6041, 0, 16}}}, 2});
    const StartupReport report = rig.start(true);
    ASSERT_FALSE(report.ok);
    const std::string expected =
        "node 5: mapping 0x1A00 on the device is 0x60640020, 0x60410010, can.yaml maps "
        "0x60410010, 0x60640020";
    bool named = false;
    for (const std::string& problem : report.problems) {
      named = named || problem.find(expected) != std::string::npos;
    }
    EXPECT_TRUE(named) << report.problems.front();
  }
}

// Found by fuzz/fuzz_can_frames (corpus file regression_nan_analogue_output): a NaN in the
// output image reached a float-to-integer conversion in write(), undefined behaviour. A NaN
// command now goes out as zero: the analogue output's safe value, the drive's standstill.
TEST(CanopenIo, NotANumberCommandGoesOutAsZero) {
  LoopbackRig rig;
  ASSERT_TRUE(rig.start(true).ok);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  OutputImage out = all_drives(true, 0.2F);
  out.drives[index(DriveId::kGuide)].speed_mps = nan;
  out.drives[index(DriveId::kGuide)].accel_mps2 = nan;
  out.hopper_opening_mm = nan;
  out.leveller_speed_rpm = 120.0F;
  out.centring_shift_mm = nan;
  rig.scan(out);
  rig.scan(out);
  EXPECT_EQ(rig.drive(DriveId::kGuide).state().target_velocity, 0);
  EXPECT_EQ(rig.drive(DriveId::kTakt).state().target_velocity, 2000);
  EXPECT_EQ(rig.drive(DriveId::kGuide).state().acceleration, 50000U);  // NaN ramp: the limit
  EXPECT_EQ(rig.module(IoModuleId::kInfeed).state().analog_outputs[0], 0);
  EXPECT_EQ(rig.module(IoModuleId::kInfeed).state().analog_outputs[1], 1200);
  EXPECT_EQ(rig.module(IoModuleId::kStations).state().analog_outputs[0], 0);
}

TEST(CanopenIo, LostDriveFaultsWithinItsTimeoutAndRecovers) {
  LoopbackRig rig;
  ASSERT_TRUE(rig.start(true).ok);
  const OutputImage out = all_drives(true, 0.3F);
  for (int i = 0; i < 10; ++i) {
    rig.scan(out);
  }
  rig.drive(DriveId::kCentring).set_silent(true);
  const std::int64_t silent_since = rig.now_ns;
  std::int64_t fault_at = 0;
  for (int i = 0; i < 50 && fault_at == 0; ++i) {
    rig.scan(out);
    if (rig.in.drives[index(DriveId::kCentring)].fault) {
      fault_at = rig.now_ns;
    }
  }
  ASSERT_NE(fault_at, 0) << "no fault within 0.5 s";
  // Heartbeat every 50 ms, timeout 150 ms: the last heartbeat came at most 50 ms before the
  // silence, so the fault shows between 100 and 150 ms plus one scan of detection delay.
  // (The TPDOs stop at once, but only the heartbeat consumer judges a node lost.)
  EXPECT_LE(fault_at - silent_since, 150'000'000 + 2 * LoopbackRig::kCycleNs);
  EXPECT_GE(fault_at - silent_since, 100'000'000 - LoopbackRig::kCycleNs);
  EXPECT_TRUE(rig.io.drive_status(DriveId::kCentring).lost);
  EXPECT_EQ(rig.io.counters().heartbeats_lost, 1U);  // the one silent node, once
  EXPECT_FALSE(rig.in.drives[index(DriveId::kCentring)].ready);
  EXPECT_FALSE(rig.in.drives[index(DriveId::kGuide)].fault);  // the others carry on

  // The cut cable also cut the drive off the master's heartbeat: back on the bus, the drive
  // finds it silent for over its 150 ms, reports EMCY 0x8130, drops to pre-operational and
  // quick-stops on its own (0x6007 = 3, set at start-up). The master starts the node again
  // from its pre-operational heartbeat; the error reset follows the next master heartbeat, and
  // the enable sequence runs once the drive stands.
  rig.drive(DriveId::kCentring).set_silent(false);
  bool quick_stopped = false;
  int scans = 0;
  for (; scans < 100 && !(rig.in.drives[index(DriveId::kCentring)].ready &&
                          !rig.in.drives[index(DriveId::kCentring)].fault);
       ++scans) {
    rig.scan(out);
    quick_stopped = quick_stopped ||
                    rig.drive(DriveId::kCentring).state().state == cia402::State::kQuickStopActive;
  }
  EXPECT_TRUE(quick_stopped);
  EXPECT_EQ(rig.drive(DriveId::kCentring).counters().heartbeats_lost, 1U);
  EXPECT_EQ(rig.io.counters().nodes_restarted, 1U);
  // Up to one 50 ms heartbeat period to learn of pre-operational, the stop from the command's
  // 0.3 m/s at the belt's rated deceleration, and three enable transitions: well within 1 s.
  EXPECT_LT(scans, 100);
  EXPECT_FALSE(rig.io.drive_status(DriveId::kCentring).lost);
  EXPECT_FALSE(rig.in.drives[index(DriveId::kCentring)].fault);
  EXPECT_TRUE(rig.in.drives[index(DriveId::kCentring)].ready);

  std::vector<CanopenEventKind> kinds;
  CanopenEvent event;
  while (rig.io.pop_event(event)) {
    if (event.node == rig.config.drives[index(DriveId::kCentring)].node_id) {
      kinds.push_back(event.kind);
    }
  }
  EXPECT_NE(std::find(kinds.begin(), kinds.end(), CanopenEventKind::kHeartbeatLost), kinds.end());
  EXPECT_NE(std::find(kinds.begin(), kinds.end(), CanopenEventKind::kHeartbeatRecovered),
            kinds.end());
}

// Every event of `kind` for `node` the master has queued, popping them all.
std::vector<CanopenEvent> events_of(LoopbackRig& rig, CanopenEventKind kind, NodeId node) {
  std::vector<CanopenEvent> found;
  CanopenEvent event;
  while (rig.io.pop_event(event)) {
    if (event.kind == kind && event.node == node) found.push_back(event);
  }
  return found;
}

TEST(CanopenIo, ARebootedDriveIsConfiguredAgainByTheCycleAndReturns) {
  LoopbackRig rig;
  ASSERT_TRUE(rig.start(true).ok);
  const OutputImage out = all_drives(true, 0.3F);
  for (int i = 0; i < 10; ++i) rig.scan(out);
  auto& drive = rig.drive(DriveId::kCentring);
  const std::size_t slot = index(DriveId::kCentring);
  // A power cycle (or the drive's own watchdog reset): every object back to its default, so
  // the drive no longer watches the master and maps nothing; a boot-up message follows.
  drive.power_cycle();
  ASSERT_EQ(drive.value(0x1016, 1), 0U);
  bool faulted = false;
  int scans = 0;
  for (; scans < 200; ++scans) {
    rig.scan(out);
    faulted = faulted || rig.in.drives[slot].fault;
    if (faulted && rig.in.drives[slot].ready && !rig.in.drives[slot].fault) break;
  }
  ASSERT_TRUE(faulted) << "the reboot was not seen";
  ASSERT_LT(scans, 200) << "the drive did not return within 2 s";
  // One SDO transfer per scan: the drive's 36 steps (device type, 4 objects, 4 PDOs of 6 or 7
  // writes, mode and 2 ramps, mode read back), then its NMT start, its first operational
  // heartbeat (50 ms) and the enable sequence.
  EXPECT_LT(scans, 36 + 20) << scans;
  EXPECT_EQ(rig.io.counters().nodes_reconfigured, 1U);
  EXPECT_EQ(rig.io.counters().reconfigurations_failed, 0U);
  // The start-up's configuration is back: the master's heartbeat watched (node 127, 150 ms,
  // can.yaml's master block) with quick stop on its loss, the PDOs mapped, profile velocity.
  EXPECT_EQ(drive.value(0x1016, 1), (127U << 16U) | 150U);
  EXPECT_EQ(drive.value(0x6007, 0), 3U);
  EXPECT_EQ(drive.value(0x1600, 0), 2U);
  EXPECT_EQ(drive.value(0x1400, 1), rig.config.drives[slot].rpdo1_cob_id);
  EXPECT_EQ(drive.state().mode, 3);
  EXPECT_EQ(drive.nmt_state(), NmtState::kOperational);
  EXPECT_FALSE(rig.io.drive_status(DriveId::kCentring).rebooted);
  EXPECT_EQ(drive.state().target_velocity, 3000);  // 0.3 m/s * 10000: it runs on the RPDOs
  const NodeId id = rig.config.drives[slot].node_id;
  CanopenEvent boot_up;
  CanopenEvent event;
  std::vector<CanopenEventKind> kinds;
  while (rig.io.pop_event(event)) {
    if (event.node != id) continue;
    kinds.push_back(event.kind);
    if (event.kind == CanopenEventKind::kBootUp) boot_up = event;
  }
  ASSERT_NE(std::find(kinds.begin(), kinds.end(), CanopenEventKind::kBootUp), kinds.end());
  EXPECT_EQ(fault_transition(boot_up), std::optional<bool>(true));  // not the master's doing
  const auto reconfigured = std::find(kinds.begin(), kinds.end(), CanopenEventKind::kReconfigured);
  ASSERT_NE(reconfigured, kinds.end());
  EXPECT_EQ(fault_transition(CanopenEvent{CanopenEventKind::kReconfigured, id}),
            std::optional<bool>(false));
  // No other drive noticed.
  for (std::size_t d = 0; d < kDriveCount; ++d) {
    if (d == slot) continue;
    EXPECT_TRUE(rig.in.drives[d].ready && !rig.in.drives[d].fault) << d;
  }

  // Configured again means watching the master again: a dead controller stops it too.
  int silent_scans = 0;
  for (; silent_scans < 30 && drive.state().state != cia402::State::kQuickStopActive;
       ++silent_scans) {
    rig.advance(LoopbackRig::kCycleNs);
  }
  EXPECT_EQ(drive.state().state, cia402::State::kQuickStopActive);
}

TEST(CanopenIo, ARebootedDriveThatAnswersLateIsConfiguredAtTheNextTry) {
  LoopbackRig rig;
  ASSERT_TRUE(rig.start(true).ok);
  const OutputImage out = all_drives(true, 0.3F);
  for (int i = 0; i < 5; ++i) rig.scan(out);
  auto& drive = rig.drive(DriveId::kGuide);
  const NodeId id = rig.config.drives[index(DriveId::kGuide)].node_id;
  drive.power_cycle();
  rig.scan(out);  // its boot-up goes out at the end of this scan
  // Still initialising: it answers nothing for half a second, past the 100 ms SDO timeout.
  drive.set_silent(true);
  rig.scan(out);  // the boot-up is read, the first request goes out unanswered
  ASSERT_TRUE(rig.io.drive_status(DriveId::kGuide).rebooted);
  for (int i = 0; i < 49; ++i) rig.scan(out);
  drive.set_silent(false);
  const std::vector<CanopenEvent> failed =
      events_of(rig, CanopenEventKind::kReconfigurationFailed, id);
  ASSERT_EQ(failed.size(), 1U);
  EXPECT_EQ(failed[0].code, 0x100000U);  // the first step: the device type, 0x1000:00
  EXPECT_EQ(static_cast<ReconfigurationFailure>(failed[0].detail),
            ReconfigurationFailure::kTimeout);
  // The next try, a second after the failure, configures it; then it is started.
  int scans = 0;
  for (; scans < 200 && rig.io.counters().nodes_reconfigured == 0; ++scans) rig.scan(out);
  ASSERT_EQ(rig.io.counters().nodes_reconfigured, 1U);
  EXPECT_GT(scans, 40);  // not before the second had passed (0.5 s of it already had)
  for (int i = 0; i < 20; ++i) rig.scan(out);
  EXPECT_FALSE(rig.io.drive_status(DriveId::kGuide).rebooted);
  EXPECT_EQ(drive.nmt_state(), NmtState::kOperational);
  EXPECT_EQ(drive.value(0x1016, 1), (127U << 16U) | 150U);
}

TEST(CanopenIo, ARebootedModuleThatRefusesItsConfigurationStaysOutAndSaysWhere) {
  LoopbackRig rig;
  ASSERT_TRUE(rig.start(true).ok);
  const OutputImage out = all_drives(true, 0.3F);
  for (int i = 0; i < 5; ++i) rig.scan(out);
  ASSERT_TRUE(rig.in.estop_ok);
  // The stations module comes back from its reboot as another build whose RPDO mapping is
  // fixed: the master's write of 0x1600:00 is refused.
  auto& module = *rig.modules[index(IoModuleId::kStations)];
  module.fix_mapping(0x1600, {{{{0x6200, 1, 8}}}, 1});
  module.power_cycle();
  // 2.5 s: the first try and two more, a second apart.
  for (int i = 0; i < 250; ++i) rig.scan(out);
  const NodeId id = rig.config.io_modules[index(IoModuleId::kStations)].node_id;
  const std::vector<CanopenEvent> failed =
      events_of(rig, CanopenEventKind::kReconfigurationFailed, id);
  ASSERT_EQ(failed.size(), 1U);
  EXPECT_EQ(failed[0].code, 0x160000U);  // 0x1600:00, the mapping's entry count
  EXPECT_EQ(static_cast<ReconfigurationFailure>(failed[0].detail),
            ReconfigurationFailure::kAborted);
  EXPECT_EQ(fault_transition(failed[0]), std::optional<bool>(true));
  EXPECT_NE(describe(failed[0]).find("0x1600:0x00: the device aborted"), std::string::npos)
      << describe(failed[0]);
  // Tried again every second, the same refusal each time: counted, reported once.
  EXPECT_EQ(rig.io.counters().reconfigurations_failed, 3U);
  EXPECT_EQ(rig.io.counters().nodes_reconfigured, 0U);
  // Not started half configured: it stays pre-operational and out, and the safety chain
  // reads open, so the line logic keeps every drive disabled.
  EXPECT_TRUE(rig.io.io_status(IoModuleId::kStations).rebooted);
  EXPECT_NE(module.nmt_state(), NmtState::kOperational);
  EXPECT_FALSE(rig.in.estop_ok);
}

// The controller dies (or its scan hangs) with the belts running: nothing more comes from the
// master, not even its heartbeat. Every device was told at start-up to watch that heartbeat,
// so each stops on its own within the consumer time: drives quick-stop, modules switch their
// outputs off and close the hopper gate. Without this a dead controller left the belts at the
// last command (the drives' RPDOs simply stop changing).
TEST(CanopenIo, DevicesStopOnTheirOwnWhenTheControllerDies) {
  LoopbackRig rig;
  ASSERT_TRUE(rig.start(true).ok);
  const std::uint32_t consumer =
      (std::uint32_t{rig.config.master.node_id} << 16U) | rig.config.master.heartbeat_timeout_ms;
  for (const auto* drive : rig.drives) {
    EXPECT_EQ(drive->value(0x1016, 1), consumer);
    EXPECT_EQ(drive->value(0x6007, 0), 3U);  // quick stop
  }
  for (const auto* module : rig.modules) {
    EXPECT_EQ(module->value(0x1016, 1), consumer);
    EXPECT_EQ(module->value(0x6206, 1), 0xFFU);  // every digital output takes its error value
    EXPECT_EQ(module->value(0x6443, 1), 1U);     // analogue outputs too
  }
  OutputImage out = all_drives(true, 0.5F);
  out.flip_plate1_flip = true;
  out.squeeze_roller_down = true;
  out.hopper_opening_mm = 80.0F;
  for (int i = 0; i < 20; ++i) rig.scan(out);
  for (const auto* drive : rig.drives) {
    ASSERT_EQ(drive->state().state, cia402::State::kOperationEnabled);
  }
  ASSERT_NE(rig.module(IoModuleId::kStations).state().digital_outputs, 0U);
  ASSERT_NE(rig.module(IoModuleId::kInfeed).state().analog_outputs[0], 0);

  // The last scan's write was the master's last frame. Its heartbeat goes out every second scan
  // (20 ms period, 10 ms scans), so the last one left 0 or 10 ms before: each device's 150 ms
  // run out 140 to 150 ms from now.
  const std::int64_t died_ns = rig.now_ns - LoopbackRig::kCycleNs;  // the last write's time
  const auto any_drive_stopped = [&rig] {
    return std::any_of(rig.drives.begin(), rig.drives.end(), [](const auto* drive) {
      return drive->state().state != cia402::State::kOperationEnabled;
    });
  };
  rig.advance(died_ns + 139'000'000 - rig.now_ns);
  EXPECT_FALSE(any_drive_stopped()) << "a device stopped before its consumer time ran out";
  rig.advance(died_ns + 151'000'000 - rig.now_ns);
  for (std::size_t d = 0; d < kDriveCount; ++d) {
    EXPECT_EQ(rig.drives[d]->state().state, cia402::State::kQuickStopActive) << "drive " << d;
    EXPECT_EQ(rig.drives[d]->counters().heartbeats_lost, 1U);
    EXPECT_EQ(rig.drives[d]->nmt_state(), canopen::NmtState::kPreOperational);
  }
  for (const auto* module : rig.modules) {
    EXPECT_EQ(module->state().digital_outputs, 0U);  // plates back, roller up, lamps off
    EXPECT_EQ(module->state().analog_outputs, (std::array<std::int16_t, 3>{}));  // gate closed
    EXPECT_EQ(module->nmt_state(), canopen::NmtState::kPreOperational);
  }
}

TEST(CanopenIo, LostSafetyModuleOpensTheEstopChain) {
  LoopbackRig rig;
  ASSERT_TRUE(rig.start(true).ok);
  const OutputImage out = all_drives(true, 0.0F);
  rig.scan(out);
  rig.scan(out);
  EXPECT_TRUE(rig.in.estop_ok);
  rig.module(IoModuleId::kSafety).set_silent(true);
  int scans = 0;
  while (rig.in.estop_ok && scans < 20) {
    rig.scan(out);
    ++scans;
  }
  EXPECT_FALSE(rig.in.estop_ok);
  // 60 ms timeout + up to one 20 ms heartbeat period + one scan: at most 9 scans.
  EXPECT_LE(scans, 9);
  EXPECT_TRUE(rig.in.stop_request);
}

TEST(CanopenIo, EmergencyFaultsTheDriveUntilTheOperatorResets) {
  LoopbackRig rig;
  ASSERT_TRUE(rig.start(true).ok);
  const OutputImage out = all_drives(true, 0.2F);
  rig.scan(out);
  rig.drive(DriveId::kSqueeze).inject_fault(0x2310);  // over current
  rig.scan(out);
  rig.scan(out);
  const DriveFeedback& squeeze = rig.in.drives[index(DriveId::kSqueeze)];
  EXPECT_TRUE(squeeze.fault);
  EXPECT_FALSE(squeeze.ready);
  EXPECT_EQ(rig.io.drive_status(DriveId::kSqueeze).emcy_code, 0x2310);
  bool emcy_logged = false;
  CanopenEvent event;
  while (rig.io.pop_event(event)) {
    if (event.kind == CanopenEventKind::kEmergency) {
      emcy_logged = true;
      EXPECT_EQ(event.code, 0x2310U);
      EXPECT_EQ(event.detail, 0x01);
      EXPECT_NE(describe(event).find("continuous over current"), std::string::npos);
    }
  }
  EXPECT_TRUE(emcy_logged);
  // No reset without the operator: still faulted 10 scans later.
  for (int i = 0; i < 10; ++i) {
    rig.scan(out);
  }
  EXPECT_TRUE(rig.in.drives[index(DriveId::kSqueeze)].fault);
  // Fault reset button (safety DI3): 0x80 edge, EMCY 0x0000, then back to enabled.
  rig.module(IoModuleId::kSafety).state().digital_inputs = 0x01 | 0x08;
  for (int i = 0; i < 10; ++i) {
    rig.scan(out);
  }
  EXPECT_FALSE(rig.in.drives[index(DriveId::kSqueeze)].fault);
  EXPECT_TRUE(rig.in.drives[index(DriveId::kSqueeze)].ready);
  EXPECT_EQ(rig.io.drive_status(DriveId::kSqueeze).emcy_code, 0);
}

TEST(CanopenIo, AnEmergencyRaisesTwoFaultsAndTheResetClearsBoth) {
  LoopbackRig rig;
  ASSERT_TRUE(rig.start(true).ok);
  const OutputImage out = all_drives(true, 0.2F);
  rig.scan(out);
  rig.io.log_events();  // start-up's events are not under test
  rig.drive(DriveId::kSqueeze).inject_fault(0x2310);
  for (int i = 0; i < 3; ++i) rig.scan(out);
  rig.module(IoModuleId::kSafety).state().digital_inputs = 0x01 | 0x08;  // fault reset
  for (int i = 0; i < 10; ++i) rig.scan(out);
  const NodeId squeeze = rig.config.drives[index(DriveId::kSqueeze)].node_id;
  std::vector<std::pair<CanopenEventKind, bool>> transitions;
  rig.io.log_events([&](const CanopenEvent& event) {
    ASSERT_EQ(event.node, squeeze) << describe(event);  // nothing else changed
    if (const std::optional<bool> raised = fault_transition(event)) {
      transitions.emplace_back(event.kind, *raised);
    }
  });
  // The EMCY and the drive's CiA 402 fault state are raised, in that order of arrival or the
  // other; the reset clears both: the fault topic ends with nothing left active.
  const auto count = [&](CanopenEventKind kind, bool raised) {
    return std::count(transitions.begin(), transitions.end(), std::make_pair(kind, raised));
  };
  EXPECT_EQ(count(CanopenEventKind::kEmergency, true), 1);
  EXPECT_EQ(count(CanopenEventKind::kDriveStateChanged, true), 1);
  EXPECT_EQ(count(CanopenEventKind::kEmergencyCleared, false), 1);
  EXPECT_EQ(count(CanopenEventKind::kDriveStateChanged, false), 1);
  EXPECT_EQ(transitions.size(), 4U);
}

TEST(CanopenIo, FaultTransitionsOfStateChangesDependOnTheStateBefore) {
  const auto event = [](CanopenEventKind kind, std::uint32_t now, std::uint8_t before) {
    return CanopenEvent{kind, 5, 0, now, before};
  };
  const auto nmt = [](NmtState state) { return static_cast<std::uint8_t>(state); };
  const auto drive = [](cia402::State state) { return static_cast<std::uint8_t>(state); };
  const auto bus = [](CanErrorState state) { return static_cast<std::uint8_t>(state); };
  using K = CanopenEventKind;
  // A node leaving Operational raises, coming back clears, pre-op to stopped is neither.
  EXPECT_EQ(fault_transition(
                event(K::kNmtStateChanged, nmt(NmtState::kStopped), nmt(NmtState::kOperational))),
            true);
  EXPECT_EQ(fault_transition(event(K::kNmtStateChanged, nmt(NmtState::kOperational),
                                   nmt(NmtState::kPreOperational))),
            false);
  EXPECT_EQ(fault_transition(event(K::kNmtStateChanged, nmt(NmtState::kStopped),
                                   nmt(NmtState::kPreOperational))),
            std::nullopt);
  // A drive entering Fault raises once; its reaction phase then Fault is no second raise.
  EXPECT_EQ(
      fault_transition(event(K::kDriveStateChanged, drive(cia402::State::kFaultReactionActive),
                             drive(cia402::State::kOperationEnabled))),
      true);
  EXPECT_EQ(fault_transition(event(K::kDriveStateChanged, drive(cia402::State::kFault),
                                   drive(cia402::State::kFaultReactionActive))),
            std::nullopt);
  EXPECT_EQ(fault_transition(event(K::kDriveStateChanged, drive(cia402::State::kSwitchOnDisabled),
                                   drive(cia402::State::kFault))),
            false);
  EXPECT_EQ(fault_transition(event(K::kDriveStateChanged, drive(cia402::State::kOperationEnabled),
                                   drive(cia402::State::kSwitchedOn))),
            std::nullopt);
  // Bus off raises and the restart clears; warning and passive still communicate.
  EXPECT_EQ(fault_transition(event(K::kBusStateChanged, bus(CanErrorState::kBusOff),
                                   bus(CanErrorState::kErrorPassive))),
            true);
  EXPECT_EQ(fault_transition(event(K::kBusStateChanged, bus(CanErrorState::kErrorActive),
                                   bus(CanErrorState::kBusOff))),
            false);
  EXPECT_EQ(fault_transition(event(K::kBusStateChanged, bus(CanErrorState::kErrorPassive),
                                   bus(CanErrorState::kErrorWarning))),
            std::nullopt);
  EXPECT_EQ(fault_transition(event(K::kBootUp, 0, 0)), true);
  EXPECT_EQ(fault_transition(event(K::kHeartbeatRecovered, 0, 0)), false);
}

TEST(CanopenIo, MalformedFramesAreCountedAndRefused) {
  LoopbackRig rig;
  ASSERT_TRUE(rig.start(true).ok);
  const OutputImage out = all_drives(true, 0.0F);
  rig.scan(out);
  const auto before = rig.io.counters();
  const std::int64_t encoder_before = rig.in.drives[index(DriveId::kBulk)].encoder_counts;

  CanFrame short_tpdo = make_frame(0x181, 3);  // TPDO1 needs 6 bytes
  short_tpdo.data = {0x08, 0x00, 0xFF};        // would read as Fault if accepted
  rig.master_bus.inject(short_tpdo);
  CanFrame long_tpdo = make_frame(0x281, 8);  // TPDO2 needs 4 bytes
  rig.master_bus.inject(long_tpdo);
  rig.master_bus.inject(make_frame(0x7E5, 1));  // heartbeat of a node not on this bus
  CanFrame bad_heartbeat = make_frame(0x701, 1);
  bad_heartbeat.data[0] = 0x33;  // no such NMT state
  rig.master_bus.inject(bad_heartbeat);
  CanFrame short_emcy = make_frame(0x081, 4);
  rig.master_bus.inject(short_emcy);
  CanFrame remote = make_frame(0x181, 6);
  remote.remote = true;
  rig.master_bus.inject(remote);
  CanFrame extended = make_frame(0x181, 6);
  extended.extended = true;
  rig.master_bus.inject(extended);
  rig.master_bus.inject(make_frame(0x581, 8));  // SDO response with no transfer running

  rig.io.read(rig.now_ns, rig.in);
  const auto& after = rig.io.counters();
  EXPECT_EQ(after.malformed_frames - before.malformed_frames, 6U);
  EXPECT_EQ(after.unknown_cob_id - before.unknown_cob_id, 1U);
  EXPECT_EQ(after.unexpected_sdo - before.unexpected_sdo, 1U);
  EXPECT_FALSE(rig.in.drives[index(DriveId::kBulk)].fault);  // the short TPDO did nothing
  EXPECT_EQ(rig.in.drives[index(DriveId::kBulk)].encoder_counts, encoder_before);
}

TEST(CanopenIo, BusOffFaultsEveryDrive) {
  LoopbackRig rig;
  ASSERT_TRUE(rig.start(true).ok);
  rig.scan(all_drives(true, 0.0F));
  rig.master_bus.set_error_state(CanErrorState::kBusOff);
  rig.io.read(rig.now_ns, rig.in);
  for (const DriveFeedback& drive : rig.in.drives) {
    EXPECT_TRUE(drive.fault);
  }
  EXPECT_FALSE(rig.in.estop_ok);
  rig.master_bus.set_error_state(CanErrorState::kErrorActive);  // the kernel restarted it
  rig.io.write(all_drives(true, 0.0F));
  rig.advance(LoopbackRig::kCycleNs);
  rig.io.read(rig.now_ns, rig.in);
  EXPECT_FALSE(rig.in.drives[0].fault);
}

TEST(CanopenIo, PositionUnwrapsAcrossTheInt32Boundary) {
  LoopbackRig rig;
  ASSERT_TRUE(rig.start(true).ok);
  auto& drive = rig.drive(DriveId::kOutfeed);
  drive.state().position_actual = 2147483647LL - 20000;  // 2 s of travel at 1 m/s from the wrap
  const OutputImage out = all_drives(true, 1.0F);
  rig.scan(out);
  const std::int64_t start = rig.in.drives[index(DriveId::kOutfeed)].encoder_counts;
  for (int i = 0; i < 300; ++i) {
    rig.scan(out);
  }
  rig.io.read(rig.now_ns, rig.in);
  const std::int64_t travelled = rig.in.drives[index(DriveId::kOutfeed)].encoder_counts - start;
  EXPECT_EQ(travelled, drive.state().position_actual - (2147483647LL - 20000) -
                           (start - (2147483647LL - 20000)));
  EXPECT_GT(drive.state().position_actual, 2147483647LL);  // the wire value wrapped
  EXPECT_GT(travelled, 25000);  // about 3 s at up to 1 m/s = 10000 counts/s
}

TEST(CanopenIo, SyncPeriodsAndSendDelaysComeFromTheBusConfirmations) {
  LoopbackRig rig;
  rig.master_bus.set_send_confirmations(true);
  ASSERT_TRUE(rig.start(true).ok);
  EXPECT_EQ(rig.io.bus_timing().syncs_on_bus, 0U);  // start-up's SDO pauses are not counted
  const OutputImage out = all_drives(true, 0.4F);
  // Four scans 10 ms apart, one late by 3 ms, then two more on time: SYNC intervals of
  // 10, 10, 10, 13, 10 ms on the bus (the first scan's SYNC has no predecessor).
  const std::array<std::int64_t, 6> gaps_ns{0,          10'000'000, 10'000'000,
                                            10'000'000, 13'000'000, 10'000'000};
  for (const std::int64_t gap_ns : gaps_ns) {
    rig.advance(gap_ns);
    rig.io.read(rig.now_ns, rig.in);
    rig.io.write(out);
  }
  rig.io.read(rig.now_ns, rig.in);  // collects the last SYNC's confirmation
  const CanBusTiming& timing = rig.io.bus_timing();
  EXPECT_EQ(timing.syncs_on_bus, 6U);
  EXPECT_EQ(timing.sync_periods, 5U);
  EXPECT_EQ(timing.sync_period_min_ns, 10'000'000);
  EXPECT_EQ(timing.sync_period_max_ns, 13'000'000);
  EXPECT_DOUBLE_EQ(timing.sync_period_mean_ns(), 10'600'000.0);  // 53 ms over 5
  EXPECT_EQ(timing.sync_jitter_ns(LoopbackRig::kCycleNs), 3'000'000);
  // Per scan 13 RPDO1s, 3 module RPDO1s and SYNC, plus the RPDO2s sent once after start-up;
  // the loopback puts a frame on the bus the moment it is sent.
  EXPECT_GE(timing.frames_confirmed, 6U * (kDriveCount + kIoModuleCount + 1));
  EXPECT_EQ(timing.send_delay_max_ns, 0);
  EXPECT_EQ(rig.master_bus.counters().sends_unconfirmed, 0U);
}

TEST(CanopenIo, AReadTellsWhenThePreviousWritesSyncWasOnTheWire) {
  LoopbackRig rig;
  rig.master_bus.set_send_confirmations(true);
  ASSERT_TRUE(rig.start(true).ok);
  const OutputImage out = all_drives(true, 0.4F);
  rig.io.read(rig.now_ns, rig.in);
  rig.io.write(out);
  const std::int64_t written_at = rig.now_ns;  // the loopback puts it on the wire at once
  rig.advance(LoopbackRig::kCycleNs);
  rig.io.read(rig.now_ns, rig.in);
  ASSERT_TRUE(rig.io.last_write_applied_ns().has_value());
  EXPECT_EQ(*rig.io.last_write_applied_ns(), written_at);
  // A read with no write since: the old SYNC is not this write's.
  rig.advance(LoopbackRig::kCycleNs);
  rig.io.read(rig.now_ns, rig.in);
  EXPECT_FALSE(rig.io.last_write_applied_ns().has_value());
  // Without confirmations the transport cannot tell.
  LoopbackRig plain;
  ASSERT_TRUE(plain.start(true).ok);
  plain.scan(out);
  plain.io.read(plain.now_ns, plain.in);
  EXPECT_FALSE(plain.io.last_write_applied_ns().has_value());
}

TEST(CanopenIo, ReadAndWriteNeitherAllocateNorLock) {
  LoopbackRig rig;
  rig.master_bus.set_send_confirmations(true);  // the confirmation path is in the cycle too
  ASSERT_TRUE(rig.start(true).ok);
  OutputImage out = all_drives(true, 0.4F);
  rig.scan(out);
  fl::test::reset_probe_counts();
  for (int i = 0; i < 100; ++i) {
    out.drives[0].accel_mps2 = i % 2 == 0 ? 1.0F : 2.0F;  // RPDO2 on change, too
    fl::test::arm_probe_on_this_thread(true);
    rig.io.read(rig.now_ns, rig.in);
    rig.io.write(out);
    fl::test::arm_probe_on_this_thread(false);
    rig.advance(LoopbackRig::kCycleNs);  // the devices may allocate: not armed
  }
  const fl::test::ProbeCounts counts = fl::test::probe_counts();
  EXPECT_EQ(counts.allocations, 0U);
  EXPECT_EQ(counts.mutex_locks, 0U);
}

}  // namespace
}  // namespace fl::drivers
