// Publish-to-take latency of CameraEstimates (a full frame of 8 estimates, the estimates
// topic's QoS) on one host, one way: the publisher stamps frame_time_ns with CLOCK_MONOTONIC
// just before dds_write, the subscriber reads CLOCK_MONOTONIC right after dds_take returns
// it (a waitset wakes it). Two runs:
//   loopback:  the publisher is a forked child process, so every sample crosses the
//              loopback interface through Cyclone's UDP stack (the line's two-process mode);
//   in-process: publisher and subscriber participants in one process, which Cyclone
//              delivers locally without the network (an upper bound on what DDS itself costs).
//
//   export CYCLONEDDS_URI=file://$PWD/config/dds/cyclonedds-loopback.xml
//   build/h-dds/drivers/dds/dds_estimate_latency [SAMPLES=10000] [INTERVAL_US=500]
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <thread>
#include <vector>

#include "fl/controller/monotonic_clock.hpp"
#include "fl/drivers/dds/convert.hpp"
#include "fl/drivers/dds/entity.hpp"
#include "fl/drivers/dds/line_output.hpp"
#include "fl/drivers/dds/qos.hpp"

namespace dds = fl::drivers::dds;

namespace {

// Domain of its own, away from the tests' 11..42.
constexpr dds_domainid_t kDomain = 77;

fl::CameraFrame full_frame(std::uint32_t sequence) {
  fl::CameraFrame frame;
  frame.sequence = sequence;
  frame.count = static_cast<std::uint8_t>(fl::kMaxEstimatesPerFrame);
  for (std::size_t i = 0; i < fl::kMaxEstimatesPerFrame; ++i) {
    frame.estimates[i].x_mm = static_cast<float>(i) * 30.0F;
    frame.estimates[i].confidence = 0.9F;
  }
  return frame;
}

void publish_loop(const dds::Participant& participant, long samples, long interval_us,
                  long warmup) {
  dds::DdsCameraPublisher publisher(participant);
  while (publisher.matched_readers() == 0) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // let discovery settle
  auto next = std::chrono::steady_clock::now();
  for (long n = 1; n <= samples + warmup; ++n) {
    fl::CameraFrame frame = full_frame(static_cast<std::uint32_t>(n));
    frame.frame_time_ns = fl::monotonic_now_ns();
    publisher.publish(fl::CameraId::kOrientation, frame);
    next += std::chrono::microseconds(interval_us);
    std::this_thread::sleep_until(next);
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // let the last ones arrive
}

struct Result {
  std::vector<std::int64_t> latencies_ns;
  // Frames the subscriber never took: keep-last 1 replaced them with a newer one before the
  // waitset thread ran (by design; on a loaded machine the thread wakes late).
  long superseded = 0;
};

Result take_loop(const dds::Participant& participant, long samples, long warmup) {
  dds::Topic topic(participant, fl_CameraEstimates_desc, dds::kEstimatesTopic);
  dds::Reader reader(participant, topic, dds::estimates_qos().get());
  const dds_entity_t waitset = dds_create_waitset(participant.get());
  const dds_entity_t condition = dds_create_readcondition(reader.get(), DDS_ANY_STATE);
  dds_waitset_attach(waitset, condition, 0);
  Result result;
  result.latencies_ns.reserve(static_cast<std::size_t>(samples));
  fl_CameraEstimates sample{};
  void* pointer = &sample;
  dds_sample_info_t info{};
  std::uint32_t last = 0;
  const std::int64_t give_up_ns = fl::monotonic_now_ns() + 120'000'000'000;  // 2 min
  while (last < static_cast<std::uint32_t>(samples + warmup) &&
         fl::monotonic_now_ns() < give_up_ns) {
    if (dds_waitset_wait(waitset, nullptr, 0, DDS_MSECS(500)) <= 0) {
      if (last > 0) break;  // the publisher finished
      continue;
    }
    while (dds_take(reader.get(), &pointer, &info, 1, 1) == 1) {
      const std::int64_t now = fl::monotonic_now_ns();
      if (!info.valid_data) continue;
      if (sample.frame_sequence > last + 1) result.superseded += sample.frame_sequence - last - 1;
      last = sample.frame_sequence;
      if (sample.frame_sequence > static_cast<std::uint32_t>(warmup)) {
        result.latencies_ns.push_back(now - sample.frame_time_ns);
      }
    }
  }
  dds_delete(waitset);
  return result;
}

void report(const char* name, Result& result) {
  auto& v = result.latencies_ns;
  if (v.empty()) {
    std::printf("%-11s no samples\n", name);
    return;
  }
  std::sort(v.begin(), v.end());
  const auto at = [&](double q) {
    return static_cast<double>(v[static_cast<std::size_t>(q * static_cast<double>(v.size() - 1))]) /
           1000.0;
  };
  std::printf(
      "%-11s n=%zu superseded=%ld  min %.1f  p50 %.1f  p90 %.1f  p99 %.1f  p99.9 %.1f  max %.1f "
      "us\n",
      name, v.size(), result.superseded, at(0.0), at(0.5), at(0.9), at(0.99), at(0.999), at(1.0));
}

}  // namespace

int main(int argc, char** argv) {
  const long samples = argc > 1 ? std::atol(argv[1]) : 10000;
  const long interval_us = argc > 2 ? std::atol(argv[2]) : 500;
  const long warmup = 100;  // the first samples pay for page faults and ARP-free first sends
  std::printf("CameraEstimates (%zu bytes in memory), %ld samples every %ld us after %ld warm-up\n",
              sizeof(fl_CameraEstimates), samples, interval_us, warmup);
  {
    const pid_t child = fork();
    if (child == 0) {
      dds::Participant participant(kDomain);
      publish_loop(participant, samples, interval_us, warmup);
      _exit(0);
    }
    Result result;
    {
      dds::Participant participant(kDomain);
      result = take_loop(participant, samples, warmup);
    }
    waitpid(child, nullptr, 0);
    report("loopback", result);
  }
  {
    dds::Participant subscriber(kDomain);
    dds::Participant publisher(kDomain);
    std::thread pub([&] { publish_loop(publisher, samples, interval_us, warmup); });
    Result result = take_loop(subscriber, samples, warmup);
    pub.join();
    report("in-process", result);
  }
  return 0;
}
