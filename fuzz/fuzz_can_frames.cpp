// CAN frames off the bus, through every CANopen decoder and into the master.
//
// Each frame of the input goes through the pure decoders (heartbeat, EMCY, SDO response and
// request, PDO unpacking with every layout of the project, NMT command, the CiA 402 status
// and control words, SocketCAN error frames) and then onto the in-process bus, where the
// master (CanopenIo, configured from config/can.yaml) and two emulated devices (a drive and an
// I/O module, which answer SDOs and NMT, on node ids of their own) receive it. Cycles run the
// master's read() and write() with an output image the input also sets (any float, NaN included:
// the master must not pass garbage to a drive). A fresh master per input keeps every crash
// reproducible from its input alone.
#include <array>
#include <cstdint>
#include <cstring>
#include <string>

#include "can_records.hpp"
#include "fl/controller/config_loader.hpp"
#include "fl/drivers/can_config.hpp"
#include "fl/drivers/canopen.hpp"
#include "fl/drivers/canopen_cia402.hpp"
#include "fl/drivers/canopen_emulation.hpp"
#include "fl/drivers/canopen_io.hpp"
#include "fl/drivers/loopback_bus.hpp"
#include "fl/drivers/socketcan.hpp"
#include "fuzz_input.hpp"

namespace {

using fl::fuzz::CanOp;
using fl::fuzz::FuzzInput;
namespace drivers = fl::drivers;
namespace canopen = fl::drivers::canopen;
namespace cia402 = fl::drivers::cia402;

constexpr std::int64_t kCycleNs = 10'000'000;
constexpr std::int64_t kClockStepNs = 100'000;

const drivers::CanConfig& can_config() {
  static const drivers::CanConfig config = [] {
    const fl::LineConfig line = fl::load_line_config(FL_SOURCE_DIR "/config/line.yaml");
    return drivers::load_can_config(FL_SOURCE_DIR "/config/can.yaml", line);
  }();
  return config;
}

// Keeps the decoders' results alive so the optimiser cannot drop the calls.
volatile std::size_t g_sink = 0;
void consume(const char* text) { g_sink = g_sink + std::strlen(text); }

void decode_everything(const drivers::CanFrame& frame) {
  if (const auto state = canopen::decode_heartbeat(frame)) consume(canopen::to_string(*state));
  if (const auto emergency = canopen::decode_emcy(frame)) {
    consume(canopen::describe_emcy_code(emergency->error_code));
  }
  const canopen::SdoResponse response = canopen::decode_sdo_response(frame);
  if (response.kind == canopen::SdoResponseKind::kAbort) {
    consume(canopen::describe_sdo_abort(response.value));
  }
  g_sink = g_sink + response.segment_bytes + response.size_bytes;
  const canopen::SdoRequest request = canopen::decode_sdo_request(frame);
  g_sink = g_sink + request.size_bytes;
  if (const auto command = canopen::decode_nmt_command(frame.data[0])) {
    g_sink = g_sink + static_cast<std::size_t>(*command);
  }

  std::array<std::uint32_t, canopen::kMaxPdoEntries> values{};
  for (const canopen::PdoMapping& mapping :
       {canopen::layout::kDriveRpdo1, canopen::layout::kDriveRpdo2, canopen::layout::kDriveTpdo1,
        canopen::layout::kDriveTpdo2, canopen::layout::kIoTpdo1, canopen::layout::kIoRpdo1}) {
    if (canopen::unpack_pdo(frame, mapping, values)) g_sink = g_sink + values[0];
  }

  const auto statusword = static_cast<std::uint16_t>(drivers::get_le(frame.data, 0, 2));
  const auto controlword = static_cast<std::uint16_t>(drivers::get_le(frame.data, 2, 2));
  const auto previous = static_cast<std::uint16_t>(drivers::get_le(frame.data, 4, 2));
  const cia402::State state = cia402::decode_statusword(statusword);
  consume(cia402::to_string(state));
  const cia402::Command command = cia402::decode_controlword(controlword, previous);
  const cia402::State next = cia402::next_state(state, command);
  g_sink = g_sink + cia402::statusword_bits(next);
  const auto goal = static_cast<cia402::Goal>(frame.data[6] % 3U);
  g_sink = g_sink + cia402::master_controlword(state, goal, (frame.data[7] & 1U) != 0U,
                                               (frame.data[7] & 2U) != 0U);
  g_sink =
      g_sink + drivers::sign_extend(drivers::get_le(frame.data, 0, 4), 1U + frame.data[7] % 32U);

  const auto bus_state = static_cast<drivers::CanErrorState>(frame.data[7] % 4U);
  consume(
      drivers::to_string(drivers::SocketCanBus::next_error_state(bus_state, frame.id, frame.data)));
}

// Sets one member of the output image from the input (a float member may be any bit pattern).
void set_output(FuzzInput& input, fl::OutputImage& out) {
  const std::uint8_t selector = input.u8();
  const std::uint32_t raw = input.u32();
  float value = 0.0F;
  std::memcpy(&value, &raw, sizeof value);
  const std::size_t drive = (selector >> 2U) % fl::kDriveCount;
  switch (selector % 4U) {
    case 0:
      out.drives[drive].speed_mps = value;
      out.drives[drive].enable = (raw & 1U) != 0U;
      break;
    case 1:
      out.drives[drive].accel_mps2 = value;
      break;
    case 2:
      switch ((selector >> 2U) % 4U) {
        case 0:
          out.hopper_opening_mm = value;
          break;
        case 1:
          out.leveller_speed_rpm = value;
          break;
        case 2:
          out.centring_shift_mm = value;
          break;
        default:
          out.state = static_cast<fl::LineState>(raw % 5U);
          break;
      }
      break;
    default:
      out.flip_plate1_flip = (raw & 0x01U) != 0U;
      out.flip_plate2_flip = (raw & 0x02U) != 0U;
      out.centring_stroke = (raw & 0x04U) != 0U;
      out.squeeze_roller_down = (raw & 0x08U) != 0U;
      out.final_reject = (raw & 0x10U) != 0U;
      break;
  }
}

void drain_events(drivers::CanopenIo& master) {
  drivers::CanopenEvent event;
  while (master.pop_event(event)) g_sink = g_sink + drivers::describe(event).size();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const drivers::CanConfig& config = can_config();
  FuzzInput input(data, size);
  std::int64_t now_ns = 1'000'000'000;
  drivers::LoopbackHub hub([&now_ns] { return now_ns; });
  drivers::LoopbackBus& master_bus = hub.add_endpoint();
  drivers::LoopbackBus& device_bus = hub.add_endpoint();
  drivers::emulation::EmulatedBusNodes devices(device_bus);
  devices.add_drive(fl::fuzz::kEmulatedDriveNode);
  devices.add_io(fl::fuzz::kEmulatedIoNode);
  drivers::CanopenIo master(master_bus, config);
  fl::InputImage in{};
  fl::OutputImage out{};

  while (!input.empty()) {
    switch (static_cast<CanOp>(input.u8() % fl::fuzz::kCanOpCount)) {
      case CanOp::kFrame: {
        const drivers::CanFrame frame = fl::fuzz::read_frame(input);
        decode_everything(frame);
        master_bus.inject(frame);
        device_bus.inject(frame);
        break;
      }
      case CanOp::kCycle:
        master.read(now_ns, in);
        master.write(out);
        devices.poll(now_ns);
        drain_events(master);
        now_ns += kCycleNs;
        break;
      case CanOp::kOutput:
        set_output(input, out);
        break;
      case CanOp::kClockStep:
        now_ns += input.u16() * kClockStepNs;
        master_bus.set_error_state(static_cast<drivers::CanErrorState>(input.u8() % 4U));
        break;
      case CanOp::kCount:
        break;
    }
  }
  master.read(now_ns, in);
  drain_events(master);
  for (std::size_t d = 0; d < fl::kDriveCount; ++d) {
    g_sink = g_sink + master.drive_status(static_cast<fl::DriveId>(d)).emcy_code;
  }
  return 0;
}
