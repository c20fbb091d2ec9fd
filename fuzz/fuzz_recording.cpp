// Recordings into load_recording (vision/record): the layer above the MCAP reader that checks
// the format version, the schemas and topics, decodes every CDR sample and truth JSON, parses
// the calibration and line.yaml attachments and checks the scans. Mutated MCAP bytes rarely get
// past the container's CRCs, so this target starts from a valid small recording (written once
// by RecordingWriter) and lets the input edit its records: flip bits in a message, cut it,
// replace it, drop or repeat it, renumber it, or replace an attachment or the metadata. The
// edited records are written again as a well-formed MCAP file, so every input reaches the
// semantic checks. The contract: a Recording or RecordingError; anything else (a crash, an
// uncaught exception, undefined behaviour) is a finding.
#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <opencv2/core.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "fl/mcap/reader.hpp"
#include "fl/mcap/writer.hpp"
#include "fl/vision/calibration.hpp"
#include "fl/vision/record/recording.hpp"
#include "fuzz_input.hpp"

namespace {

namespace fs = std::filesystem;
namespace mcap = fl::mcap;
namespace record = fl::vision::record;

// Record edits, one opcode byte each (the operands follow).
enum class Edit : std::uint8_t {
  kFlipByte,           // message, offset, xor mask
  kCut,                // message, new length
  kReplaceMessage,     // message, length, bytes
  kDrop,               // message
  kRepeat,             // message (appended again)
  kRenumber,           // message, sequence, log time
  kReplaceAttachment,  // attachment, length, bytes
  kMetadataValue,      // key (one of the metadata's), length, bytes
  kCount,
};

// Payloads the input supplies are at most this long: a frame's PNG and a sample fit.
constexpr std::size_t kMaxPayloadBytes = 4096;

struct Contents {
  std::vector<mcap::Schema> schemas;
  std::vector<mcap::Channel> channels;
  std::vector<mcap::Message> messages;
  std::vector<mcap::Attachment> attachments;
  std::vector<mcap::Metadata> metadata;
};

fs::path scratch_path(const char* what) {
  return fs::temp_directory_path() /
         ("fuzz_recording_" + std::to_string(getpid()) + "_" + what + ".mcap");
}

std::string read_text(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// Two scans of the orientation camera: two 32 x 24 frames with their estimates and truth,
// the camera's calibration and line.yaml attached, as `linectl record` writes them.
Contents make_template() {
  const fs::path path = scratch_path("template");
  {
    record::WriterSettings settings;
    settings.info = {{"source", "fuzz_recording"}};
    record::RecordingWriter writer(path, settings);
    const fl::CameraId camera = fl::CameraId::kOrientation;
    writer.add_camera(
        camera, fl::vision::load_calibration(FL_SOURCE_DIR "/config/camera_orientation.yaml"));
    writer.attach_line_config(read_text(FL_SOURCE_DIR "/config/line.yaml"));
    fl::InputImage in{};
    const fl::OutputImage out{};
    for (std::uint32_t scan = 0; scan < 2; ++scan) {
      in.time_ns = 1'000'000'000 + static_cast<std::int64_t>(scan) * 10'000'000;
      fl::CameraFrame& frame = in.cameras[fl::index(camera)];
      frame.sequence = scan + 1;
      frame.frame_time_ns = in.time_ns - 5'000'000;
      frame.count = 1;
      frame.estimates[0].x_mm = 12.5F;
      frame.estimates[0].angle_rad = 0.3F;
      frame.estimates[0].confidence = 0.9F;
      frame.estimates[0].hand = fl::Hand::kLeft;
      frame.estimates[0].side = fl::SideUp::kSkin;
      frame.estimates[0].singulated = true;
      const cv::Mat image(24, 32, CV_8UC3, cv::Scalar(40, 90, 160));
      writer.write_frame(camera, frame.sequence, frame.frame_time_ns, image);
      fl::vision::TrueFillet truth;
      truth.x_mm = 12.0;
      truth.angle_rad = 0.3;
      truth.hand = fl::Hand::kLeft;
      truth.side = fl::SideUp::kSkin;
      writer.write_truth(camera, frame.sequence, frame.frame_time_ns, {truth});
      writer.write_estimates(camera, in.time_ns, frame);
      writer.write_scan(scan, in, out);
    }
    writer.close();
  }
  const mcap::Reader reader = mcap::Reader::open(path);
  fs::remove(path);
  Contents contents;
  for (const auto& [id, schema] : reader.summary().schemas) contents.schemas.push_back(schema);
  for (const auto& [id, channel] : reader.summary().channels) contents.channels.push_back(channel);
  contents.messages = reader.read_messages();
  for (const mcap::AttachmentIndex& index : reader.summary().attachment_indexes) {
    contents.attachments.push_back(reader.read_attachment(index));
  }
  for (const mcap::MetadataIndex& index : reader.summary().metadata_indexes) {
    contents.metadata.push_back(reader.read_metadata(index));
  }
  return contents;
}

mcap::Bytes take_bytes(fl::fuzz::FuzzInput& input, std::size_t length) {
  mcap::Bytes bytes;
  for (std::size_t k = 0; k < length && !input.empty(); ++k) bytes.push_back(input.u8());
  return bytes;
}

void apply_edits(fl::fuzz::FuzzInput& input, Contents& contents) {
  while (!input.empty()) {
    const auto edit = static_cast<Edit>(input.u8() % static_cast<std::uint8_t>(Edit::kCount));
    auto& messages = contents.messages;
    if (edit == Edit::kReplaceAttachment) {
      if (contents.attachments.empty()) continue;
      mcap::Attachment& attachment = contents.attachments[input.u8() % contents.attachments.size()];
      attachment.data = take_bytes(input, input.u16() % kMaxPayloadBytes);
      continue;
    }
    if (edit == Edit::kMetadataValue) {
      if (contents.metadata.empty() || contents.metadata.front().metadata.empty()) continue;
      auto& values = contents.metadata.front().metadata;
      const auto entry =
          std::next(values.begin(), static_cast<std::ptrdiff_t>(input.u8() % values.size()));
      const mcap::Bytes value = take_bytes(input, input.u8());
      entry->second.assign(value.begin(), value.end());
      continue;
    }
    if (messages.empty()) return;
    const std::size_t at = input.u16() % messages.size();
    mcap::Message& message = messages[at];
    switch (edit) {
      case Edit::kFlipByte: {
        const std::uint16_t offset = input.u16();
        const std::uint8_t mask = input.u8();
        if (!message.data.empty()) {
          std::uint8_t& byte = message.data[offset % message.data.size()];
          byte = static_cast<std::uint8_t>(byte ^ mask);
        }
        break;
      }
      case Edit::kCut:
        if (!message.data.empty()) message.data.resize(input.u16() % message.data.size());
        break;
      case Edit::kReplaceMessage:
        message.data = take_bytes(input, input.u16() % kMaxPayloadBytes);
        break;
      case Edit::kDrop:
        messages.erase(messages.begin() + static_cast<std::ptrdiff_t>(at));
        break;
      case Edit::kRepeat:
        messages.push_back(message);
        break;
      case Edit::kRenumber:
        message.sequence = input.u32();
        message.log_time = input.u64();
        break;
      default:
        break;
    }
  }
}

// The edited records as a well-formed file: ids as they were, uncompressed chunks.
void write_contents(const fs::path& path, const Contents& contents) {
  mcap::WriterOptions options;
  options.compression = mcap::Compression::kNone;
  mcap::Writer writer(path, options);
  std::map<std::uint16_t, std::uint16_t> schema_ids;
  for (const mcap::Schema& schema : contents.schemas) {
    schema_ids[schema.id] = writer.add_schema(schema.name, schema.encoding, schema.data);
  }
  std::map<std::uint16_t, std::uint16_t> channel_ids;
  for (const mcap::Channel& channel : contents.channels) {
    channel_ids[channel.id] = writer.add_channel(schema_ids[channel.schema_id], channel.topic,
                                                 channel.message_encoding, channel.metadata);
  }
  for (const mcap::Metadata& metadata : contents.metadata) writer.write_metadata(metadata);
  for (const mcap::Attachment& attachment : contents.attachments) {
    writer.write_attachment(attachment);
  }
  for (const mcap::Message& message : contents.messages) {
    writer.write_message({channel_ids[message.channel_id], message.sequence, message.log_time,
                          message.publish_time, message.data});
  }
  writer.close();
}

volatile std::size_t g_sink = 0;

// The file each input is written to, removed when the fuzzer exits.
struct ScratchFile {
  fs::path path = scratch_path("input");
  ScratchFile() = default;
  ScratchFile(const ScratchFile&) = delete;
  ScratchFile& operator=(const ScratchFile&) = delete;
  ~ScratchFile() {
    std::error_code ignored;
    fs::remove(path, ignored);
  }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const Contents kTemplate = make_template();
  static const ScratchFile kScratch;
  Contents contents = kTemplate;
  fl::fuzz::FuzzInput input(data, size);
  apply_edits(input, contents);
  write_contents(kScratch.path, contents);
  try {
    const record::Recording recording = record::load_recording(kScratch.path);
    g_sink = g_sink + recording.message_count + recording.scans.size() + recording.estimates.size();
  } catch (const record::RecordingError&) {
    // refused, naming the file and the record: the contract
  }
  return 0;
}
