// drivers_dds_peer: the other process of the DDS tests (a camera node or a subscriber),
// built only from fl_drivers_dds. The configuration comes from CYCLONEDDS_URI.
//
//   drivers_dds_peer publish DOMAIN CAMERA PERIOD_MS FRAMES AFTER
//     waits up to 10 s for a reader, publishes FRAMES frames (0: until killed) of
//     make_frame() every PERIOD_MS (0: with no pause, a flooding camera node, offering the
//     slowest camera's deadline), then AFTER = exit (clean shutdown) | hang (stays alive,
//     silent: the reader's deadline passes while liveliness holds).
//   drivers_dds_peer subscribe DOMAIN SECONDS
//     reads estimates for SECONDS and prints "accepted=N matched=M".
// Exit codes: 0 done, 2 usage, 3 participant refused, 4 reader/writer refused,
// 5 no reader matched within 10 s.
#include <spdlog/spdlog.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <string>
#include <thread>

#include "dds_test_support.hpp"
#include "fl/controller/monotonic_clock.hpp"
#include "fl/drivers/dds/camera_input.hpp"
#include "fl/drivers/dds/line_output.hpp"

namespace dds = fl::drivers::dds;
using namespace std::chrono_literals;

namespace {

int publish(dds_domainid_t domain, int camera, int period_ms, long frames,
            const std::string& after) {
  std::optional<dds::Participant> participant;
  try {
    participant.emplace(domain);
  } catch (const dds::DdsError& e) {
    std::printf("participant refused: %s\n", e.what());
    return 3;
  }
  std::optional<dds::DdsCameraPublisher> publisher;
  try {
    publisher.emplace(*participant, period_ms > 0 ? static_cast<std::int64_t>(period_ms) * 1'000'000
                                                  : dds::kSlowestCameraPeriodNs);
  } catch (const dds::DdsError& e) {
    std::printf("writer refused: %s\n", e.what());
    std::fflush(stdout);
    return 4;
  }
  if (!dds::test::wait_until([&] { return publisher->matched_readers() > 0; }, 10s)) {
    std::printf("no reader\n");
    std::fflush(stdout);
    if (after == "hang") {
      for (;;) std::this_thread::sleep_for(1s);
    }
    return 5;
  }
  // Matching is asymmetric: this writer has seen the reader, the reader may not yet have
  // seen this writer, and a volatile reader drops what comes before. Discovery on loopback
  // takes a few ms; 100 ms covers a loaded machine without slowing the tests much.
  std::this_thread::sleep_for(100ms);
  const auto cam = static_cast<fl::CameraId>(camera);
  auto next = std::chrono::steady_clock::now();
  for (long n = 1; frames == 0 || n <= frames; ++n) {
    publisher->publish(
        cam, dds::test::make_frame(cam, static_cast<std::uint32_t>(n), fl::monotonic_now_ns()));
    next += std::chrono::milliseconds(period_ms);
    std::this_thread::sleep_until(next);
  }
  std::printf("published=%ld\n", frames);
  std::fflush(stdout);
  if (after == "hang") {
    for (;;) std::this_thread::sleep_for(1s);
  }
  return 0;
}

int subscribe(dds_domainid_t domain, int seconds) {
  std::optional<dds::Participant> participant;
  try {
    participant.emplace(domain);
  } catch (const dds::DdsError& e) {
    std::printf("participant refused: %s\n", e.what());
    return 3;
  }
  std::optional<dds::DdsCameraInput> input;
  try {
    input.emplace(*participant);
  } catch (const dds::DdsError& e) {
    std::printf("reader refused: %s\n", e.what());
    return 4;
  }
  std::this_thread::sleep_for(std::chrono::seconds(seconds));
  std::printf("accepted=%llu matched=%u\n",
              static_cast<unsigned long long>(input->counters().samples_accepted),
              input->matched_writers());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  spdlog::set_level(spdlog::level::warn);
  const std::string mode = argc > 1 ? argv[1] : "";
  if (mode == "publish" && argc == 7) {
    return publish(static_cast<dds_domainid_t>(std::atoi(argv[2])), std::atoi(argv[3]),
                   std::atoi(argv[4]), std::atol(argv[5]), argv[6]);
  }
  if (mode == "subscribe" && argc == 4) {
    return subscribe(static_cast<dds_domainid_t>(std::atoi(argv[2])), std::atoi(argv[3]));
  }
  std::fprintf(stderr, "usage: see drivers/dds/tests/peer_main.cpp\n");
  return 2;
}
