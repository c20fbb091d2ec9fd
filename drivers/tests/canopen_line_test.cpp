// The line's logic on the CANopen master (fault matrix, docs/fault_matrix.md): the scan as
// the runtime runs it, read() -> LineController::update() -> write(), against emulated
// CiA 402 drives and CiA 401 modules on the loopback bus. A bus fault must reach the input
// image in the read that meets it, and the controller must stop the line in that same scan.
#include <gtest/gtest.h>

#include "fl/controller/line_controller.hpp"
#include "loopback_rig.hpp"

namespace fl::drivers {
namespace {

using test::LoopbackRig;

struct LineOnCan {
  LoopbackRig rig;
  LineConfig line = test::reference_line_config();
  LineController controller{line};
  OutputImage out{};

  // One scan as ScanRuntime runs it: the scheduled time in the image, then read, update,
  // write; then a period passes on the bus.
  void scan() {
    rig.in.time_ns = rig.now_ns;
    rig.io.read(rig.now_ns, rig.in);
    controller.update(rig.in, out);
    rig.io.write(out);
    rig.advance(LoopbackRig::kCycleNs);
  }

  // Start-up over the bus, then a start request: running within a few scans.
  void start_line() {
    ASSERT_TRUE(rig.start(true).ok);
    controller.request_start();
    // Stopped -> starting -> running takes two scans once every drive reports ready; 10
    // leaves room for the first TPDOs after start-up.
    for (int i = 0; i < 10 && controller.state() != LineState::kRunning; ++i) scan();
    ASSERT_EQ(controller.state(), LineState::kRunning);
  }

  void expect_line_stopped_this_scan() const {
    EXPECT_EQ(out.state, LineState::kFault);
    EXPECT_NE(out.active_faults & fault_bit(FaultCode::kDriveFault), 0U);
    for (const DriveCommand& drive : out.drives) EXPECT_EQ(drive.speed_mps, 0.0F);
  }
};

// An EMCY frame on the bus: fault in the read that receives it, line fault in that scan,
// every drive commanded to standstill by the write that follows.
TEST(CanopenLine, EmergencyStopsTheLineInTheScanThatReadsIt) {
  LineOnCan line;
  line.start_line();
  const DriveId squeeze = DriveId::kSqueeze;
  canopen::Emergency emergency;
  emergency.error_code = 0x2310;  // continuous over current
  emergency.error_register = 0x03;
  line.rig.master_bus.inject(
      canopen::make_emcy(line.rig.config.drives[index(squeeze)].node_id, emergency));
  line.rig.in.time_ns = line.rig.now_ns;
  line.rig.io.read(line.rig.now_ns, line.rig.in);
  EXPECT_TRUE(line.rig.in.drives[index(squeeze)].fault);  // the same read
  EXPECT_FALSE(line.rig.in.drives[index(squeeze)].ready);
  line.controller.update(line.rig.in, line.out);
  line.expect_line_stopped_this_scan();
  line.rig.io.write(line.out);
  line.rig.advance(LoopbackRig::kCycleNs);
  // The zero speeds reached every drive with that scan's RPDOs (the chain is closed, so the
  // drives stay enabled and hold the belts at standstill).
  for (std::size_t d = 0; d < kDriveCount; ++d) {
    EXPECT_EQ(line.rig.drives[d]->state().target_velocity, 0) << "drive " << d;
  }
}

// An I/O module's emergency (here the stations module, whose inputs are the plates' and the
// roller's end switches): its inputs cannot be trusted, so the chain reads open in the read
// that receives it and every drive is disabled in that scan; the error reset (EMCY code 0)
// closes the chain again in the next read.
TEST(CanopenLine, IoModuleEmergencyOpensTheChainUntilItIsReset) {
  LineOnCan line;
  line.start_line();
  const std::uint8_t stations = line.rig.config.io_modules[index(IoModuleId::kStations)].node_id;
  canopen::Emergency emergency;
  emergency.error_code = 0x5000;  // device hardware
  emergency.error_register = 0x01;
  line.rig.master_bus.inject(canopen::make_emcy(stations, emergency));
  line.rig.in.time_ns = line.rig.now_ns;
  line.rig.io.read(line.rig.now_ns, line.rig.in);
  EXPECT_FALSE(line.rig.in.estop_ok);  // the same read
  line.controller.update(line.rig.in, line.out);
  EXPECT_EQ(line.out.state, LineState::kFault);
  for (const DriveCommand& drive : line.out.drives) EXPECT_FALSE(drive.enable);
  line.rig.io.write(line.out);
  line.rig.advance(LoopbackRig::kCycleNs);

  canopen::Emergency reset;  // error code 0: the module's errors are gone
  line.rig.master_bus.inject(canopen::make_emcy(stations, reset));
  line.rig.in.time_ns = line.rig.now_ns;
  line.rig.io.read(line.rig.now_ns, line.rig.in);
  EXPECT_TRUE(line.rig.in.estop_ok);
}

// The same from the emulated drive itself: it trips, reports its fault (EMCY and statusword)
// with the SYNC that ends the next write, and the controller stops the line in the first scan
// whose read sees it: at most two scans after the trip.
TEST(CanopenLine, DriveThatTripsStopsTheLineWithinTwoScans) {
  LineOnCan line;
  line.start_line();
  line.rig.drive(DriveId::kMultilane1Left).inject_fault(0x7121);  // motor blocked
  bool fault = false;
  for (int i = 0; i < 2 && !fault; ++i) {
    line.scan();
    fault = line.rig.in.drives[index(DriveId::kMultilane1Left)].fault;
  }
  ASSERT_TRUE(fault);
  line.expect_line_stopped_this_scan();
  EXPECT_EQ(line.rig.io.drive_status(DriveId::kMultilane1Left).emcy_code, 0x7121);
}

// A drive that reboots mid-run (a power dip, its watchdog) comes back with none of the
// start-up's configuration. The line stops in the scan that reads its boot-up; the master
// configures it again from the cycle, and after the operator's acknowledgement the line
// starts with every drive, this one included.
TEST(CanopenLine, DriveThatRebootsStopsTheLineAndIsConfiguredAgainForTheRestart) {
  LineOnCan line;
  line.start_line();
  auto& takt = line.rig.drive(DriveId::kTakt);
  takt.power_cycle();
  bool stopped = false;
  for (int i = 0; i < 2 && !stopped; ++i) {  // the boot-up goes out with the next bus step
    line.scan();
    stopped = line.out.state == LineState::kFault;
  }
  ASSERT_TRUE(stopped);
  line.expect_line_stopped_this_scan();
  // 36 SDO transfers, one per scan, then NMT start: within a second.
  for (int i = 0; i < 100 && line.rig.io.counters().nodes_reconfigured == 0; ++i) line.scan();
  ASSERT_EQ(line.rig.io.counters().nodes_reconfigured, 1U);
  EXPECT_EQ(line.controller.state(), LineState::kFault);  // nothing restarts by itself
  // Its first operational heartbeat (50 ms), then the operator.
  for (int i = 0; i < 10; ++i) line.scan();
  line.controller.acknowledge_faults();
  line.scan();
  ASSERT_EQ(line.controller.state(), LineState::kStopped) << line.out.active_faults;
  line.controller.request_start();
  for (int i = 0; i < 20 && line.controller.state() != LineState::kRunning; ++i) line.scan();
  ASSERT_EQ(line.controller.state(), LineState::kRunning) << line.out.active_faults;
  EXPECT_EQ(takt.state().state, cia402::State::kOperationEnabled);
  EXPECT_EQ(takt.nmt_state(), canopen::NmtState::kOperational);
  EXPECT_EQ(takt.value(0x6007, 0), 3U);  // quick stop when the master falls silent, again
}

// Bus off: every drive faulted and the safety chain open in the read that sees the error
// state; the controller disables every drive in the same scan.
TEST(CanopenLine, BusOffDisablesEveryDriveInTheSameScan) {
  LineOnCan line;
  line.start_line();
  line.rig.master_bus.set_error_state(CanErrorState::kBusOff);
  line.scan();
  EXPECT_FALSE(line.rig.in.estop_ok);
  line.expect_line_stopped_this_scan();
  EXPECT_NE(line.out.active_faults & fault_bit(FaultCode::kEstop), 0U);
  for (const DriveCommand& drive : line.out.drives) EXPECT_FALSE(drive.enable);
  // The kernel restarts the controller; the line stays down until the operator acknowledges
  // and starts it again.
  line.rig.master_bus.set_error_state(CanErrorState::kErrorActive);
  for (int i = 0; i < 5; ++i) line.scan();
  EXPECT_EQ(line.controller.state(), LineState::kFault);
}

// A babbling node floods the bus: each read() handles at most 8 batches (512 frames) and
// returns, so the scan keeps its time; the line runs on meanwhile, and an EMCY queued behind the
// flood still stops the line in the scan whose read reaches it.
TEST(CanopenLine, FrameFloodIsDrainedInBoundedReadsAndAFaultBehindItStillStops) {
  LineOnCan line;
  line.start_line();
  // 900 frames: more than one read may take, and with a cycle's own traffic (about 40
  // frames) still inside the loopback queue of 1024.
  constexpr std::uint64_t kFlood = 900;
  for (std::uint64_t i = 0; i < kFlood; ++i) {
    line.rig.master_bus.inject(make_frame(0x7E5, 1));  // heartbeat of a node not on this bus
  }
  canopen::Emergency emergency;
  emergency.error_code = 0x3210;  // DC link over voltage
  line.rig.master_bus.inject(
      canopen::make_emcy(line.rig.config.drives[index(DriveId::kTakt)].node_id, emergency));
  const CanopenCounters before = line.rig.io.counters();
  line.scan();
  const std::uint64_t first_read = line.rig.io.counters().frames_handled - before.frames_handled;
  EXPECT_EQ(first_read, CanopenIo::kReceiveBatch * CanopenIo::kMaxBatchesPerRead);
  EXPECT_EQ(line.out.state, LineState::kRunning);  // the EMCY is still queued
  line.scan();
  EXPECT_EQ(line.rig.io.counters().unknown_cob_id - before.unknown_cob_id, kFlood);
  EXPECT_TRUE(line.rig.in.drives[index(DriveId::kTakt)].fault);
  line.expect_line_stopped_this_scan();
}

}  // namespace
}  // namespace fl::drivers
