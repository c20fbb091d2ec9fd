#include "mcap_test_support.hpp"

#include <algorithm>
#include <set>
#include <sstream>
#include <string_view>

namespace fl::mcap::test {

namespace {

ByteView text_bytes(std::string_view text) {
  return {reinterpret_cast<const std::uint8_t*>(text.data()), text.size()};
}

}  // namespace

Bytes frame_payload(int index, std::size_t size) {
  Bytes data(size);
  for (std::size_t k = 0; k < size; ++k) {
    // Varies with index and position so chunks neither repeat nor compress to nothing.
    data[k] =
        static_cast<std::uint8_t>(static_cast<std::size_t>(index) * 131U + k * 7U + (k >> 8U));
  }
  return data;
}

// 30 frames per second (33.333 ms), from a 2023 Unix time in nanoseconds: realistic values
// that need all 64 bits' worth of care (above 2^53).
Timestamp frame_time(int index) {
  return 1'700'000'000'000'000'000ULL + static_cast<Timestamp>(index) * 33'333'333ULL;
}

WrittenFile write_recording(WriterOptions options, const RecordingShape& shape) {
  options.chunk_size = shape.chunk_size;
  std::ostringstream stream;
  WrittenFile file;
  {
    Writer writer(stream, options);
    const std::string image_schema = "uint32 height\nuint32 width\nuint8[] data\n";
    const std::string event_schema = R"({"type":"object"})";
    const std::uint16_t image =
        writer.add_schema("sensor_msgs/msg/Image", "ros2msg", text_bytes(image_schema));
    const std::uint16_t event =
        writer.add_schema("fl/LineEvent", "jsonschema", text_bytes(event_schema));
    const std::uint16_t channels[] = {
        writer.add_channel(image, kTopics[0], "cdr", {{"camera", "left"}}),
        writer.add_channel(image, kTopics[1], "cdr", {{"camera", "right"}}),
        writer.add_channel(event, kTopics[2], "json")};
    if (shape.with_attachment_and_metadata) {
      const std::string calibration = "camera: left\nfx: 1400.5\n";
      writer.write_attachment({frame_time(0), frame_time(0) - 1, "calibration.yaml",
                               "application/yaml", Bytes(calibration.begin(), calibration.end())});
      writer.write_metadata({"line", {{"line_id", "fillet-1"}, {"camera_count", "2"}}});
    }
    for (int i = 0; i < shape.message_count; ++i) {
      const int stream_index = i % 3;
      // Events are 16..22 bytes; 7919 (a prime) spreads frame sizes over the range.
      const std::size_t size = stream_index == 2
                                   ? 16U + static_cast<std::size_t>(i % 7)
                                   : shape.frame_min_bytes + static_cast<std::size_t>(i) * 7919U %
                                                                 shape.frame_spread_bytes;
      // Shuffled: every 5th message is stamped 40 frames late, so chunk time ranges overlap.
      const int time_index = shape.shuffle_times && i % 5 == 0 ? i + 40 : i;
      Message message{channels[stream_index], static_cast<std::uint32_t>(i), frame_time(time_index),
                      frame_time(time_index) - 1000, frame_payload(i, size)};
      writer.write_message({message.channel_id, message.sequence, message.log_time,
                            message.publish_time, message.data});
      file.messages.push_back(std::move(message));
    }
    writer.close();
    file.statistics = writer.statistics();
  }
  const std::string text = std::move(stream).str();
  file.bytes.assign(text.begin(), text.end());
  return file;
}

MessageFilter time_filter(Timestamp start, Timestamp end, std::vector<std::string> topics) {
  MessageFilter filter;
  filter.start_time = start;
  filter.end_time = end;
  filter.topics = std::move(topics);
  return filter;
}

MessageFilter topic_filter(std::vector<std::string> topics) {
  MessageFilter filter;
  filter.topics = std::move(topics);
  return filter;
}

WriterOptions compressed(Compression compression) {
  WriterOptions options;
  options.compression = compression;
  return options;
}

RecordingShape shape(int message_count, std::uint64_t chunk_size) {
  RecordingShape result;
  result.message_count = message_count;
  result.chunk_size = chunk_size;
  return result;
}

ReaderOptions without_crc_checks() {
  ReaderOptions options;
  options.validate_crcs = false;
  return options;
}

std::string compression_test_name(const ::testing::TestParamInfo<Compression>& param_info) {
  const std::string_view name = compression_name(param_info.param);
  return name.empty() ? std::string("none") : std::string(name);
}

std::vector<std::size_t> probe_offsets(const Bytes& bytes) {
  std::set<std::size_t> offsets;
  for (std::size_t at = 0; at < bytes.size(); at += 17) offsets.insert(at);
  std::size_t record = kMagic.size();
  while (record + kRecordPrefixSize <= bytes.size()) {
    std::uint64_t length = 0;
    for (std::size_t i = 0; i < 8; ++i) length |= std::uint64_t{bytes[record + 1 + i]} << (8 * i);
    const std::size_t end = record + kRecordPrefixSize + static_cast<std::size_t>(length);
    for (std::size_t at = record; at < std::min(end, record + 64); ++at) offsets.insert(at);
    for (std::size_t at = end >= 8 ? end - 8 : 0; at < end; ++at) offsets.insert(at);
    record = end;
  }
  for (std::size_t at = 0; at < kMagic.size(); ++at) {
    offsets.insert(at);
    offsets.insert(bytes.size() - 1 - at);
  }
  return {offsets.begin(), offsets.end()};
}

Reader open_bytes(const Bytes& bytes, ReaderOptions options) {
  return Reader(std::make_unique<MemorySource>(bytes), options);
}

bool same_message(const Message& a, const Message& b) {
  return a.channel_id == b.channel_id && a.sequence == b.sequence && a.log_time == b.log_time &&
         a.publish_time == b.publish_time && a.data == b.data;
}

bool is_prefix(const std::vector<Message>& prefix, const std::vector<Message>& all) {
  if (prefix.size() > all.size()) return false;
  for (std::size_t i = 0; i < prefix.size(); ++i) {
    if (!same_message(prefix[i], all[i])) return false;
  }
  return true;
}

}  // namespace fl::mcap::test
