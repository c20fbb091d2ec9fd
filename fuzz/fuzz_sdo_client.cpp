// SDO client transfers against whatever a server (or anything else on the bus) answers.
//
// The input is a script: upload and download requests to any node and address, and the
// frames the bus hands out in between (a response from the transfer's node, or any other
// identifier, which the client passes on to its other-frames callback). The client's
// blocking waits run on a simulated clock; once the script has no frames left every wait
// times out at once, so an input never runs for the real 100 ms per transfer.
#include <cstdint>
#include <deque>

#include "can_records.hpp"
#include "fl/drivers/can_bus.hpp"
#include "fl/drivers/canopen.hpp"
#include "fl/drivers/canopen_sdo_client.hpp"
#include "fuzz_input.hpp"

namespace {

using fl::fuzz::FuzzInput;
using fl::fuzz::SdoOp;
namespace drivers = fl::drivers;
namespace canopen = fl::drivers::canopen;

constexpr std::int64_t kSdoTimeoutNs = 100'000'000;  // config/can.yaml's sdo_timeout_ms

volatile std::size_t g_sink = 0;

// Hands out the script's frames one receive() at a time; refuses nothing it is given.
class ScriptedBus final : public drivers::CanBus {
 public:
  explicit ScriptedBus(FuzzInput& input) : input_(input) {}

  bool send(const drivers::CanFrame& frame) override {
    g_sink = g_sink + frame.dlc;
    ++counters_.frames_sent;
    return true;
  }

  // Reads the script up to the next frame, running the transfers it asks for in between.
  std::size_t receive(std::span<drivers::CanFrame> out) override {
    if (out.empty() || input_.empty()) return 0;
    switch (static_cast<SdoOp>(input_.u8() % fl::fuzz::kSdoOpCount)) {
      case SdoOp::kResponse: {
        const bool from_node = (input_.u8() & 1U) != 0U;
        drivers::CanFrame frame = fl::fuzz::read_frame(input_);
        if (from_node) {
          frame.id = canopen::kSdoResponseBase + node_;
          frame.extended = false;
          frame.remote = false;
        }
        out[0] = frame;
        ++counters_.frames_received;
        return 1;
      }
      default:
        return 0;  // a quiet poll; a request in the middle of a transfer is not one
    }
  }

  [[nodiscard]] drivers::CanErrorState error_state() const override {
    return drivers::CanErrorState::kErrorActive;
  }
  [[nodiscard]] const drivers::CanBusCounters& counters() const override { return counters_; }

  void set_node(canopen::NodeId node) { node_ = node; }

 private:
  FuzzInput& input_;
  canopen::NodeId node_ = 1;
  drivers::CanBusCounters counters_;
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  FuzzInput input(data, size);
  ScriptedBus bus(input);
  std::int64_t now_ns = 0;
  // Time passes only by waiting; with the script spent, a wait jumps past any deadline.
  const drivers::BusClock clock{[&now_ns] { return now_ns; },
                                [&now_ns, &input](std::int64_t duration_ns) {
                                  now_ns += input.empty() ? kSdoTimeoutNs : duration_ns;
                                }};
  drivers::SdoClient client(bus, clock, kSdoTimeoutNs,
                            [](const drivers::CanFrame& frame) { g_sink = g_sink + frame.id; });

  while (!input.empty()) {
    const auto op = static_cast<SdoOp>(input.u8() % fl::fuzz::kSdoOpCount);
    if (op != SdoOp::kUpload && op != SdoOp::kDownload) continue;  // no transfer to answer
    const auto node = static_cast<canopen::NodeId>(canopen::kMinNodeId +
                                                   input.u8() % canopen::kMaxNodeId);  // 1..127
    const canopen::SdoAddress address{input.u16(), input.u8()};
    bus.set_node(node);
    drivers::SdoResult result;
    if (op == SdoOp::kUpload) {
      result = client.upload(node, address);
    } else {
      const std::uint32_t value = input.u32();
      const auto size_bytes = static_cast<std::uint8_t>(1U + input.u8() % 4U);
      result = client.download(node, address, value, size_bytes);
    }
    g_sink = g_sink + result.describe().size() + result.bytes.size();
  }
  const drivers::SdoClientCounters& counters = client.counters();
  g_sink = g_sink + counters.transfers + counters.malformed_responses;
  return 0;
}
