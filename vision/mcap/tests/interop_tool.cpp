// Helper for the interoperability test with @mcap/core (interop/interop.mjs):
//   mcap_interop_tool write DIR    writes ours_none.mcap, ours_zstd.mcap, ours_lz4.mcap
//   mcap_interop_tool check FILE   reads a file (written by @mcap/core) and checks it
// Both sides generate the same content from the message index alone; the formulas here
// and in interop.mjs must stay identical.

#include <cstdio>
#include <exception>
#include <filesystem>
#include <string>
#include <string_view>

#include "fl/mcap/reader.hpp"
#include "fl/mcap/writer.hpp"

namespace {

using namespace fl::mcap;

constexpr int kMessageCount = 240;  // 80 per channel, several chunks of 32 KiB
constexpr const char* kTopics[] = {"/camera/left/image", "/camera/right/image", "/line/events"};
constexpr Timestamp kStartTime = 1'700'000'000'000'000'000ULL;  // above 2^53: needs BigInt in JS
constexpr Timestamp kFramePeriod = 33'333'333;                  // 30 frames per second

Timestamp log_time(int index) { return kStartTime + static_cast<Timestamp>(index) * kFramePeriod; }

std::size_t payload_size(int index) {
  return index % 3 == 2 ? 16U + static_cast<std::size_t>(index % 7)
                        : 1000U + static_cast<std::size_t>(index * 7919 % 9000);
}

Bytes payload(int index) {
  Bytes data(payload_size(index));
  for (std::size_t k = 0; k < data.size(); ++k) {
    data[k] =
        static_cast<std::uint8_t>(static_cast<std::size_t>(index) * 131U + k * 7U + (k >> 8U));
  }
  return data;
}

ByteView text(std::string_view value) {
  return {reinterpret_cast<const std::uint8_t*>(value.data()), value.size()};
}

const std::string kCalibration = "camera: left\nfx: 1400.5\n";

void write_file(const std::filesystem::path& path, Compression compression) {
  WriterOptions options;
  options.compression = compression;
  options.chunk_size = 32 * 1024;
  options.profile = "";
  Writer writer(path, options);
  const std::uint16_t image = writer.add_schema(
      "sensor_msgs/msg/Image", "ros2msg", text("uint32 height\nuint32 width\nuint8[] data\n"));
  const std::uint16_t event =
      writer.add_schema("fl/LineEvent", "jsonschema", text(R"({"type":"object"})"));
  const std::uint16_t channels[] = {
      writer.add_channel(image, kTopics[0], "cdr", {{"camera", "left"}}),
      writer.add_channel(image, kTopics[1], "cdr", {{"camera", "right"}}),
      writer.add_channel(event, kTopics[2], "json")};
  writer.write_attachment({kStartTime, kStartTime - 1, "calibration.yaml", "application/yaml",
                           Bytes(kCalibration.begin(), kCalibration.end())});
  writer.write_metadata({"line", {{"line_id", "fillet-1"}, {"camera_count", "2"}}});
  for (int i = 0; i < kMessageCount; ++i) {
    const Bytes data = payload(i);
    writer.write_message(
        {channels[i % 3], static_cast<std::uint32_t>(i), log_time(i), log_time(i) - 1000, data});
  }
  writer.close();
}

int fail(const std::string& why) {
  std::fprintf(stderr, "mcap_interop_tool: %s\n", why.c_str());
  return 1;
}

int check_file(const std::filesystem::path& path) {
  const Reader reader = Reader::open(path);
  if (!reader.indexed()) return fail(path.string() + ": no chunk indexes");
  const std::vector<Message> messages = reader.read_messages();
  if (messages.size() != kMessageCount) {
    return fail(path.string() + ": " + std::to_string(messages.size()) + " messages, expected " +
                std::to_string(kMessageCount));
  }
  for (int i = 0; i < kMessageCount; ++i) {
    const Message& message = messages[static_cast<std::size_t>(i)];
    const Channel& channel = reader.summary().channels.at(message.channel_id);
    if (message.sequence != static_cast<std::uint32_t>(i) || channel.topic != kTopics[i % 3] ||
        message.log_time != log_time(i) || message.publish_time != log_time(i) - 1000 ||
        message.data != payload(i)) {
      return fail(path.string() + ": message " + std::to_string(i) + " differs");
    }
  }
  // An indexed, filtered read: events of frames 60..119.
  MessageFilter filter;
  filter.start_time = log_time(60);
  filter.end_time = log_time(119);
  filter.topics = {kTopics[2]};
  const std::vector<Message> events = reader.read_messages(filter);
  if (events.size() != 20) {
    return fail(path.string() + ": filtered read gave " + std::to_string(events.size()));
  }
  const Summary& summary = reader.summary();
  if (!summary.statistics || summary.statistics->message_count != kMessageCount) {
    return fail(path.string() + ": statistics missing or wrong");
  }
  if (summary.attachment_indexes.size() != 1 ||
      reader.read_attachment(summary.attachment_indexes[0]).data !=
          Bytes(kCalibration.begin(), kCalibration.end())) {
    return fail(path.string() + ": attachment missing or wrong");
  }
  if (summary.metadata_indexes.size() != 1 ||
      reader.read_metadata(summary.metadata_indexes[0]).metadata.at("line_id") != "fillet-1") {
    return fail(path.string() + ": metadata missing or wrong");
  }
  const ScanResult scanned = scan_file(path);
  if (!scanned.complete || scanned.messages.size() != kMessageCount) {
    return fail(path.string() + ": linear scan stopped: " + scanned.stop_reason);
  }
  std::string compressions;
  for (const ChunkIndex& index : summary.chunk_indexes) {
    if (compressions.find("[" + index.compression + "]") == std::string::npos) {
      compressions += "[" + index.compression + "]";
    }
  }
  std::printf("fl_mcap read %s: %d messages in %zu chunks %s, library '%s'\n",
              path.filename().c_str(), kMessageCount, summary.chunk_indexes.size(),
              compressions.c_str(), reader.header().library.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) return fail("usage: mcap_interop_tool write DIR | check FILE");
  const std::string command = argv[1];
  try {
    if (command == "write") {
      const std::filesystem::path directory = argv[2];
      std::filesystem::create_directories(directory);
      write_file(directory / "ours_none.mcap", Compression::kNone);
      write_file(directory / "ours_zstd.mcap", Compression::kZstd);
      write_file(directory / "ours_lz4.mcap", Compression::kLz4);
      return 0;
    }
    if (command == "check") return check_file(argv[2]);
  } catch (const std::exception& error) {
    return fail(error.what());
  }
  return fail("unknown command " + command);
}
