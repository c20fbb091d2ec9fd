// The status snapshots for operator screens: the triple buffer hands the newest complete
// snapshot across threads, and the publisher fills it from the controller and the images.
#include "fl/controller/line_status.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <thread>

#include "fl/controller/line_config.hpp"

namespace fl {
namespace {

struct Numbered {
  std::uint64_t sequence = 0;
  std::array<std::uint64_t, 64> copies{};  // all equal to sequence in a complete snapshot
};

TEST(TripleBuffer, ReaderGetsTheNewestPublishedValue) {
  TripleBuffer<Numbered> buffer;
  EXPECT_FALSE(buffer.take());
  for (std::uint64_t n = 1; n <= 3; ++n) {
    buffer.back().sequence = n;
    buffer.publish();
  }
  ASSERT_TRUE(buffer.take());
  EXPECT_EQ(buffer.front().sequence, 3U);
  EXPECT_FALSE(buffer.take());  // nothing new: front keeps the last one
  EXPECT_EQ(buffer.front().sequence, 3U);
}

TEST(TripleBuffer, ConcurrentReaderNeverSeesATornOrOlderSnapshot) {
  TripleBuffer<Numbered> buffer;
  constexpr std::uint64_t kWrites = 200'000;
  std::atomic<bool> done{false};
  std::thread writer([&] {
    for (std::uint64_t n = 1; n <= kWrites; ++n) {
      Numbered& slot = buffer.back();
      slot.sequence = n;
      slot.copies.fill(n);
      buffer.publish();
    }
    done.store(true);
  });
  std::uint64_t last = 0;
  std::uint64_t taken = 0;
  while (true) {
    const bool finished = done.load();
    if (buffer.take()) {
      const Numbered& seen = buffer.front();
      ASSERT_GT(seen.sequence, last);
      for (const std::uint64_t copy : seen.copies) ASSERT_EQ(copy, seen.sequence);
      last = seen.sequence;
      ++taken;
    } else if (finished) {
      break;
    }
  }
  writer.join();
  EXPECT_EQ(last, kWrites);  // the final value always arrives
  EXPECT_GT(taken, 0U);
}

TEST(LineStatusPublisher, FillsTheSnapshotFromControllerImagesAndTiming) {
  const LineConfig config = default_line_config();
  LineController controller(config);
  InputImage in{};
  in.time_ns = 10'000'000;
  in.estop_ok = true;
  in.flip_plate2_flipping = true;
  in.drives[index(DriveId::kGuide)].speed_mps = 0.49F;
  OutputImage out{};
  controller.update(in, out);
  out.drives[index(DriveId::kReject)].speed_mps = -1.0F;
  LineStatusPublisher publisher;
  for (std::uint64_t scan = 1; scan <= 150; ++scan) {
    const std::int64_t latency_ns = scan == 20 ? 90'000 : 10'000;
    publisher.publish(controller, in, out,
                      ScanTimingSample{10'000'000, latency_ns, 200'000, scan, 0});
  }
  ASSERT_TRUE(publisher.buffer().take());
  const LineStatus& status = publisher.buffer().front();
  EXPECT_EQ(status.sequence, 150U);
  EXPECT_EQ(status.time_ns, 10'000'000);
  EXPECT_TRUE(status.estop_ok);
  EXPECT_TRUE(status.flip_plate2_flipping);
  EXPECT_TRUE(status.reject_reversing);
  EXPECT_FLOAT_EQ(status.drives[index(DriveId::kGuide)].speed_mps, 0.49F);
  EXPECT_EQ(status.counters.scans, 1U);
  EXPECT_EQ(status.timing.scans, 150U);
  EXPECT_EQ(status.timing.max_wakeup_latency_ns, 90'000);
  // Scan 20 lies in the last completed window (scans 1..100), which is the one shown.
  EXPECT_EQ(status.timing.window_max_wakeup_latency_ns, 90'000);
  for (std::uint64_t scan = 151; scan <= 200; ++scan) {
    publisher.publish(controller, in, out, ScanTimingSample{10'000'000, 10'000, 200'000, scan, 0});
  }
  ASSERT_TRUE(publisher.buffer().take());
  EXPECT_EQ(publisher.buffer().front().timing.window_max_wakeup_latency_ns, 10'000);
  EXPECT_EQ(publisher.buffer().front().timing.max_wakeup_latency_ns, 90'000);
}

}  // namespace
}  // namespace fl
