// The real-time contract: DdsCameraInput::read() and DdsLineOutput::write() on an armed
// scan thread neither allocate nor lock while Cyclone delivers and publishes on its own
// threads, counted with the runtime's scan-thread probe as drivers/tests does for CANopen.
// The contrast case shows why the design needs the hand-over: dds_take itself locks.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>

#include "dds_test_support.hpp"
#include "fl/drivers/dds/camera_input.hpp"
#include "fl/drivers/dds/line_output.hpp"
#include "scan_thread_probe.hpp"

namespace fl::drivers::dds {
namespace {

using namespace std::chrono_literals;
using test::wait_until;

TEST(DdsRealtime, ReadAndWriteNeitherAllocateNorLockWhileDataFlows) {
  Participant controller(41);
  Participant camera_node(41);
  DdsCameraInput input(controller);
  DdsLineOutput output(controller);
  DdsCameraPublisher publisher(camera_node);
  ASSERT_TRUE(wait_until([&] { return publisher.matched_readers() == 1; }, 5s));

  std::atomic<bool> stop{false};
  std::thread camera([&] {
    for (std::uint32_t s = 1; !stop.load(); ++s) {
      publisher.publish(CameraId::kMultilane1, test::make_frame(CameraId::kMultilane1, s, s));
      std::this_thread::sleep_for(1ms);
    }
  });
  // 300 scans of 1 ms: several hundred frames delivered and commands published meanwhile.
  constexpr int kScans = 300;
  InputImage in;
  OutputImage out;
  std::uint32_t frames_seen = 0;
  std::uint32_t last_sequence = 0;
  fl::test::ProbeCounts counts{};
  std::thread scan([&] {
    fl::test::reset_probe_counts();
    fl::test::ArmedProbeScope armed;
    for (int i = 0; i < kScans; ++i) {
      input.read(in);
      const std::uint32_t sequence = in.cameras[index(CameraId::kMultilane1)].sequence;
      if (sequence != last_sequence) {
        last_sequence = sequence;
        ++frames_seen;
      }
      out.drives[0].speed_mps = static_cast<float>(i);
      output.write(static_cast<std::int64_t>(i) * 1'000'000, out);
      std::this_thread::sleep_for(1ms);  // sleeping is the runtime's part, outside the probe
    }
    counts = fl::test::probe_counts();
  });
  scan.join();
  stop = true;
  camera.join();
  EXPECT_EQ(counts.allocations, 0U);
  EXPECT_EQ(counts.deallocations, 0U);
  EXPECT_EQ(counts.mutex_locks, 0U);
  // Data really flowed through both paths while the probe was armed.
  EXPECT_GT(frames_seen, static_cast<std::uint32_t>(kScans / 10));
  ASSERT_TRUE(wait_until([&] { return output.counters().commands_published > 0; }, 2s));
}

TEST(DdsRealtime, DdsTakeOnTheScanThreadWouldLock) {
  Participant controller(42);
  Topic topic(controller, fl_CameraEstimates_desc, kEstimatesTopic);
  Reader reader(controller, topic, estimates_qos().get());
  fl_CameraEstimates sample{};
  void* pointer = &sample;
  dds_sample_info_t info{};
  fl::test::reset_probe_counts();
  {
    fl::test::ArmedProbeScope armed;
    (void)dds_take(reader.get(), &pointer, &info, 1, 1);
  }
  EXPECT_GT(fl::test::probe_counts().mutex_locks, 0U)
      << "dds_take no longer locks: the listener hand-over could be reconsidered";
}

}  // namespace
}  // namespace fl::drivers::dds
