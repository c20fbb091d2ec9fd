// DDS samples as the controller's intake receives them, through its validation and
// conversion (drivers/dds convert.hpp) and on into the line controller.
//
// A sample's members come from the input one by one, in IDL order, with any bit pattern: a
// float may be NaN or infinite, an enum any 32-bit value (a local writer's C struct is not
// deserialised, so nothing but validate() checks it; a remote one is range-checked by
// Cyclone first, a subset of this). Booleans are 0 or 1, as Cyclone delivers them and as a C
// writer can hold them. Accepted samples go where the intake puts them (camera frames and
// sensors into the input image, drive feedback into its drive), and scans run the line
// controller (config/line.yaml) on the image: what validate() lets through must not upset
// the logic. Line commands take the line I/O side's conversion.
#include <cstdint>
#include <cstring>
#include <type_traits>

#include "fillet_line.h"
#include "fl/controller/config_loader.hpp"
#include "fl/controller/line_controller.hpp"
#include "fl/drivers/dds/convert.hpp"
#include "fuzz_input.hpp"

namespace {

using fl::fuzz::DdsKind;
using fl::fuzz::FuzzInput;
namespace dds = fl::drivers::dds;

constexpr std::int64_t kScanNs = 10'000'000;

const fl::LineConfig& line_config() {
  static const fl::LineConfig config = fl::load_line_config(FL_SOURCE_DIR "/config/line.yaml");
  return config;
}

volatile std::size_t g_sink = 0;

// An IDL enum member as a C writer may fill it: any value of the underlying integer.
template <typename Enum>
void read_enum(FuzzInput& input, Enum& member) {
  static_assert(sizeof(Enum) == sizeof(std::uint32_t));
  const std::uint32_t raw = input.u32();
  std::memcpy(&member, &raw, sizeof raw);
}

fl_CameraEstimates read_camera_estimates(FuzzInput& input) {
  fl_CameraEstimates sample{};
  sample.camera_id = input.u8();
  sample.frame_time_ns = input.i64();
  sample.frame_sequence = input.u32();
  sample.count = input.u8();
  for (fl_FilletEstimate& e : sample.estimates) {
    e.x_mm = input.f32();
    e.y_mm = input.f32();
    e.angle_rad = input.f32();
    e.confidence = input.f32();
    read_enum(input, e.hand);
    read_enum(input, e.side);
    e.singulated = input.boolean();
  }
  return sample;
}

fl_LineSensors read_line_sensors(FuzzInput& input) {
  fl_LineSensors sample{};
  sample.time_ns = input.i64();
  sample.scan = input.u64();
  sample.takt_beam_broken = input.boolean();
  sample.level_mm = input.f32();
  sample.hopper_opening_mm = input.f32();
  sample.leveller_speed_rpm = input.f32();
  sample.leveller_overload = input.boolean();
  sample.flip_plate1_flipping = input.boolean();
  sample.flip_plate2_flipping = input.boolean();
  sample.centring_position_mm = input.f32();
  sample.squeeze_roller_down = input.boolean();
  sample.estop_ok = input.boolean();
  sample.start_request = input.boolean();
  sample.stop_request = input.boolean();
  sample.fault_reset_request = input.boolean();
  return sample;
}

fl_DriveFeedback read_drive_feedback(FuzzInput& input) {
  fl_DriveFeedback sample{};
  sample.drive_id = input.u8();
  sample.time_ns = input.i64();
  sample.speed_mps = input.f32();
  sample.encoder_counts = input.i64();
  sample.ready = input.boolean();
  sample.fault = input.boolean();
  return sample;
}

fl_LineCommand read_line_command(FuzzInput& input) {
  fl_LineCommand sample{};
  sample.time_ns = input.i64();
  sample.scan = input.u64();
  for (fl_DriveCommand& drive : sample.drives) {
    drive.enable = input.boolean();
    drive.speed_mps = input.f32();
    drive.accel_mps2 = input.f32();
  }
  sample.hopper_opening_mm = input.f32();
  sample.leveller_speed_rpm = input.f32();
  sample.flip_plate1_flip = input.boolean();
  sample.flip_plate2_flip = input.boolean();
  sample.centring_shift_mm = input.f32();
  sample.centring_stroke = input.boolean();
  sample.squeeze_roller_down = input.boolean();
  sample.final_reject = input.boolean();
  return sample;
}

void drain(fl::LineController& controller) {
  while (const auto record = controller.closed_records().pop()) g_sink = g_sink + 1;
  while (const auto event = controller.events().pop()) g_sink = g_sink + 1;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  FuzzInput input(data, size);
  fl::LineController controller(line_config());
  controller.request_start();
  fl::InputImage in{};
  fl::OutputImage out{};
  std::int64_t now_ns = 1'000'000'000;

  while (!input.empty()) {
    switch (static_cast<DdsKind>(input.u8() % fl::fuzz::kDdsKindCount)) {
      case DdsKind::kCameraEstimates: {
        const fl_CameraEstimates sample = read_camera_estimates(input);
        if (const auto reason = dds::validate(sample)) {
          g_sink = g_sink + std::strlen(dds::to_string(*reason));
          break;
        }
        dds::from_idl(sample, in.cameras[sample.camera_id]);
        fl_CameraEstimates echo{};
        dds::to_idl(static_cast<fl::CameraId>(sample.camera_id), in.cameras[sample.camera_id],
                    echo);
        break;
      }
      case DdsKind::kLineSensors: {
        const fl_LineSensors sample = read_line_sensors(input);
        g_sink = g_sink + (dds::from_idl(sample, in) ? 1U : 0U);
        break;
      }
      case DdsKind::kDriveFeedback: {
        const fl_DriveFeedback sample = read_drive_feedback(input);
        fl::DriveId drive{};
        fl::DriveFeedback feedback{};
        if (dds::from_idl(sample, drive, feedback)) in.drives[fl::index(drive)] = feedback;
        break;
      }
      case DdsKind::kLineCommand: {
        const fl_LineCommand sample = read_line_command(input);
        fl::OutputImage command{};
        dds::from_idl(sample, command);
        fl_LineCommand echo{};
        dds::to_idl(now_ns, 0, command, echo);
        break;
      }
      case DdsKind::kScan:
        in.time_ns = now_ns;
        controller.update(in, out);
        drain(controller);
        now_ns += kScanNs;
        break;
      case DdsKind::kCount:
        break;
    }
  }
  in.time_ns = now_ns;
  controller.update(in, out);
  controller.close_all_in_transit(now_ns, fl::LostReason::kRunEnded);
  drain(controller);
  return 0;
}
