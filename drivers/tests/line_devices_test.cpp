// LineDevices and CanopenPlant: every signal of the process images through the CANopen
// master and the plant-backed emulated devices, against a scripted plant, so that each
// field's channel, scaling and delay is checked on its own (the closed-loop test in
// hil_tests judges the whole line).
#include "fl/drivers/line_devices.hpp"

#include <gtest/gtest.h>

#include <vector>

#include "loopback_rig.hpp"

namespace fl::drivers {
namespace {

// A plant that plays back a given input image and keeps every output image it was given.
class ScriptedPlant final : public Plant {
 public:
  [[nodiscard]] const char* name() const override { return "scripted"; }
  void reset(std::uint64_t /*seed*/, InputImage& in) override {
    next.time_ns = 0;
    in = next;
  }
  void step(const OutputImage& out, std::int64_t dt_ns, InputImage& in) override {
    received.push_back(out);
    next.time_ns += dt_ns;
    in = next;
  }
  std::span<const TrueFilletExit> drain_exits() override { return {}; }
  [[nodiscard]] std::uint64_t fillets_fed() const override { return 0; }
  [[nodiscard]] std::uint64_t fillets_on_line() const override { return 0; }

  InputImage next{};
  std::vector<OutputImage> received;
};

constexpr std::int64_t kPeriodNs = 10'000'000;

InputImage plant_reading() {
  InputImage in{};
  for (std::size_t d = 0; d < kDriveCount; ++d) {
    // Distinct per drive, both directions, on whole velocity units (1e-4 m/s, can.yaml).
    in.drives[d].speed_mps = 0.1F * static_cast<float>(d + 1) * (d % 2 == 0 ? 1.0F : -1.0F);
    in.drives[d].encoder_counts = 1000 * static_cast<std::int64_t>(d + 1);
  }
  in.takt_beam_broken = true;
  in.leveller_overload = false;
  in.level_mm = 123.45F;  // whole counts of 0.01 mm
  in.hopper_opening_mm = 55.5F;
  in.leveller_speed_rpm = 30.2F;
  in.flip_plate1_flipping = true;
  in.flip_plate2_flipping = false;
  in.squeeze_roller_down = true;
  in.centring_position_mm = -12.5F;
  in.estop_ok = true;
  in.cameras[0].sequence = 7;  // cameras bypass the bus
  return in;
}

// The scripted plant behind the bus of config/can.yaml, reset (the master's start-up done)
// with the safety chain closed.
class CanopenPlantTest : public ::testing::Test {
 protected:
  void SetUp() override {
    inner.next.estop_ok = true;
    plant.reset(1, in);
    ASSERT_TRUE(plant.startup().ok);
  }

  ScriptedPlant inner;
  CanopenPlant plant{inner, test::reference_can_config()};
  InputImage in{};
};

TEST_F(CanopenPlantTest, EverySensorAndFeedbackReachesTheMasterOneSyncLater) {
  EXPECT_FALSE(in.takt_beam_broken);  // the empty plant of reset

  inner.next = plant_reading();
  const OutputImage out = test::all_drives(true, 0.0F);
  // Step 1: the plant moves to the new reading after the SYNC has sampled the old one.
  plant.step(out, kPeriodNs, in);
  EXPECT_FALSE(in.takt_beam_broken) << "a reading taken after the SYNC came too early";
  EXPECT_EQ(in.cameras[0].sequence, 7U) << "cameras are not on the bus: no delay";
  plant.step(out, kPeriodNs, in);
  const InputImage expected = plant_reading();
  EXPECT_EQ(in.time_ns, 2 * kPeriodNs);
  for (std::size_t d = 0; d < kDriveCount; ++d) {
    EXPECT_FLOAT_EQ(in.drives[d].speed_mps, expected.drives[d].speed_mps) << "drive " << d;
    EXPECT_EQ(in.drives[d].encoder_counts, expected.drives[d].encoder_counts) << "drive " << d;
    EXPECT_TRUE(in.drives[d].ready) << "drive " << d;
    EXPECT_FALSE(in.drives[d].fault) << "drive " << d;
  }
  EXPECT_TRUE(in.takt_beam_broken);
  EXPECT_FALSE(in.leveller_overload);
  // Analogue channels: within half a count of their scaling.
  EXPECT_NEAR(in.level_mm, expected.level_mm, 0.005);
  EXPECT_NEAR(in.hopper_opening_mm, expected.hopper_opening_mm, 0.005);
  EXPECT_NEAR(in.leveller_speed_rpm, expected.leveller_speed_rpm, 0.05);
  EXPECT_NEAR(in.centring_position_mm, expected.centring_position_mm, 0.005);
  EXPECT_TRUE(in.flip_plate1_flipping);
  EXPECT_FALSE(in.flip_plate2_flipping);
  EXPECT_TRUE(in.squeeze_roller_down);
  EXPECT_TRUE(in.estop_ok);
  EXPECT_FALSE(in.start_request);
}

TEST_F(CanopenPlantTest, EveryCommandReachesThePlantAtTheSync) {
  OutputImage out{};
  out.state = LineState::kRunning;
  for (std::size_t d = 0; d < kDriveCount; ++d) {
    out.drives[d].enable = d != 3;  // one drive held off
    out.drives[d].speed_mps = 0.05F * static_cast<float>(d + 1);
    out.drives[d].accel_mps2 = 0.5F;
  }
  out.hopper_opening_mm = 40.0F;
  out.leveller_speed_rpm = 120.0F;
  out.flip_plate1_flip = false;
  out.flip_plate2_flip = true;
  out.centring_shift_mm = -7.25F;
  out.centring_stroke = true;
  out.squeeze_roller_down = true;
  out.final_reject = true;
  plant.step(out, kPeriodNs, in);
  ASSERT_EQ(inner.received.size(), 1U);
  const OutputImage& got = inner.received.back();
  for (std::size_t d = 0; d < kDriveCount; ++d) {
    EXPECT_EQ(got.drives[d].enable, d != 3) << "drive " << d;
    // The master sends a target only to a drive in Operation Enabled; speed in units of
    // 1e-4 m/s, acceleration of 1e-4 m/s^2 (can.yaml).
    EXPECT_NEAR(got.drives[d].speed_mps, d != 3 ? out.drives[d].speed_mps : 0.0F, 1e-4)
        << "drive " << d;
    EXPECT_NEAR(got.drives[d].accel_mps2, 0.5F, 1e-4) << "drive " << d;
  }
  EXPECT_NEAR(got.hopper_opening_mm, 40.0F, 0.005);
  EXPECT_NEAR(got.leveller_speed_rpm, 120.0F, 0.05);
  EXPECT_FALSE(got.flip_plate1_flip);
  EXPECT_TRUE(got.flip_plate2_flip);
  EXPECT_NEAR(got.centring_shift_mm, -7.25F, 0.005);
  EXPECT_TRUE(got.centring_stroke);
  EXPECT_TRUE(got.squeeze_roller_down);
  EXPECT_TRUE(got.final_reject);
  EXPECT_EQ(got.state, LineState::kRunning);  // the running lamp
}

TEST_F(CanopenPlantTest, APlantDriveFaultReachesTheMasterAsAnEmergency) {
  const OutputImage out = test::all_drives(true, 0.0F);
  const auto takt = static_cast<std::size_t>(DriveId::kTakt);
  inner.next.drives[takt].fault = true;
  // The fault enters the device after step 1's SYNC; the EMCY and the Fault state go out at
  // the next SYNC and are read at the scan after it.
  for (int scan = 0; scan < 3; ++scan) plant.step(out, kPeriodNs, in);
  EXPECT_TRUE(in.drives[takt].fault);
  EXPECT_FALSE(in.drives[takt].ready);
  const NodeStatus status = plant.master().drive_status(DriveId::kTakt);
  EXPECT_EQ(status.emcy_code, emulation::LineDevices::kPlantDriveFaultCode);
  // The others run on.
  EXPECT_TRUE(in.drives[takt + 1].ready);

  // A fault reset while the plant still reports the fault: the drive trips again, as a real
  // drive whose cause remains (the emulated drive taken out of Fault as the reset would).
  emulation::EmulatedCia402Drive& drive = plant.devices().drive(DriveId::kTakt);
  drive.state().state = cia402::State::kSwitchOnDisabled;
  drive.state().error_code = 0;
  for (int scan = 0; scan < 3; ++scan) plant.step(out, kPeriodNs, in);
  EXPECT_TRUE(in.drives[takt].fault) << "a fault the plant still reports was forgotten";
  EXPECT_EQ(plant.master().drive_status(DriveId::kTakt).emcy_code,
            emulation::LineDevices::kPlantDriveFaultCode);
}

}  // namespace
}  // namespace fl::drivers
