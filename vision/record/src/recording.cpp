#include "fl/vision/record/recording.hpp"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <set>
#include <sstream>

#include "fl/mcap/reader.hpp"
#include "fl/mcap/writer.hpp"
#include "idl_text.hpp"
#include "png_decode.hpp"

namespace fl::vision::record {
namespace {

constexpr std::int64_t kNsPerS = 1'000'000'000;

// ROS 2's sensor_msgs/msg/CompressedImage with its dependencies, in the concatenated form
// rosbag2 writes into MCAP schemas (each dependency after a line of 80 '=').
constexpr std::string_view kCompressedImageMsg =
    "std_msgs/Header header\n"
    "string format\n"
    "uint8[] data\n"
    "================================================================================\n"
    "MSG: std_msgs/Header\n"
    "builtin_interfaces/Time stamp\n"
    "string frame_id\n"
    "================================================================================\n"
    "MSG: builtin_interfaces/Time\n"
    "int32 sec\n"
    "uint32 nanosec\n";

constexpr std::string_view kCompressedImageSchema = "sensor_msgs/msg/CompressedImage";
constexpr std::string_view kCameraEstimatesSchema = "fl::CameraEstimates";
constexpr std::string_view kLineCommandSchema = "fl::LineCommand";
constexpr std::string_view kLineStatusSchema = "fl::LineStatus";
constexpr std::string_view kDriveFeedbackSchema = "fl::DriveFeedback";
constexpr std::string_view kLineSensorsSchema = "fl::LineSensors";
constexpr std::string_view kCameraTruthSchema = "fl.CameraTruth";
// JSON Schema of the truth channel's messages, so that Foxglove and other tools show them.
// clang-format off
constexpr std::string_view kCameraTruthJsonSchema = R"json({
  "title": "fl.CameraTruth",
  "description": "The fillets as they truly lay in one twin camera frame, camera belt frame",
  "type": "object",
  "properties": {
    "camera": {"type": "string"},
    "sequence": {"type": "integer"},
    "exposure_ns": {"type": "integer"},
    "fillets": {"type": "array", "items": {"type": "object", "properties": {
      "x_mm": {"type": "number"}, "y_mm": {"type": "number"},
      "angle_rad": {"type": "number", "description": "thick end to tip, from travel, CCW"},
      "hand": {"enum": ["left", "right"]}, "side": {"enum": ["skin", "bone"]},
      "group_id": {"type": "integer", "description": "0 or more: fillets sharing it touch"},
      "singulated": {"type": "boolean"}, "fully_visible": {"type": "boolean"},
      "gap_mm": {"type": "number", "description": "least distance to another fillet; absent: none"}}}}
  }
})json";
// clang-format on

std::string seconds(std::int64_t ns) {
  char text[48];
  std::snprintf(text, sizeof text, "%.9f s", static_cast<double>(ns) / 1e9);
  return text;
}

mcap::ByteView view(std::string_view text) {
  return {reinterpret_cast<const std::uint8_t*>(text.data()), text.size()};
}

std::string calibration_yaml(const BeltCalibration& calibration) {
  // save_calibration writes a file (with round-trip precision and the header comments);
  // go through a temporary one so that the attachment is exactly what config/ would hold.
  const std::filesystem::path file = std::filesystem::temp_directory_path() /
                                     ("fl_record_calibration_" + std::to_string(::getpid()) + "_" +
                                      calibration.camera_name + ".yaml");
  save_calibration(file, calibration);
  std::ifstream in(file);
  std::stringstream text;
  text << in.rdbuf();
  in.close();
  std::filesystem::remove(file);
  return text.str();
}

}  // namespace

std::string_view camera_name(CameraId camera) { return to_string(camera); }

std::optional<CameraId> camera_from_name(std::string_view name) { return parse<CameraId>(name); }

std::string image_topic(CameraId camera) {
  return "/camera/" + std::string(camera_name(camera)) + "/image";
}
std::string estimates_topic(CameraId camera) {
  return "/camera/" + std::string(camera_name(camera)) + "/estimates";
}
std::string truth_topic(CameraId camera) {
  return "/camera/" + std::string(camera_name(camera)) + "/truth";
}
std::string calibration_attachment(CameraId camera) {
  return "camera_" + std::string(camera_name(camera)) + ".yaml";
}

std::string_view fillet_line_idl() { return kFilletLineIdl; }
std::string_view compressed_image_msg() { return kCompressedImageMsg; }

// ------------------------------------------------------------------ writer

RecordingWriter::RecordingWriter(const std::filesystem::path& path, WriterSettings settings)
    : settings_(std::move(settings)) {
  mcap::WriterOptions options;
  options.library = "fl_vision_record";
  // A recorder on the line can lose power: every closed chunk must be on the disk.
  options.sync_chunks = true;
  writer_ = std::make_unique<mcap::Writer>(path, options);
  settings_.info["format_version"] = std::string(kRecordingFormatVersion);
  writer_->write_metadata({std::string(kInfoMetadataName), settings_.info});
  // The line channels exist in every recording; a vision-only one simply has no messages there.
  sensors_channel_ =
      writer_->add_channel(schema(kLineSensorsSchema), std::string(kSensorsTopic), "cdr");
  drive_channel_ =
      writer_->add_channel(schema(kDriveFeedbackSchema), std::string(kDriveFeedbackTopic), "cdr");
  command_channel_ =
      writer_->add_channel(schema(kLineCommandSchema), std::string(kCommandTopic), "cdr");
  status_channel_ =
      writer_->add_channel(schema(kLineStatusSchema), std::string(kStatusTopic), "cdr");
}

RecordingWriter::~RecordingWriter() = default;

std::uint16_t RecordingWriter::schema(std::string_view name) {
  if (auto it = schemas_.find(name); it != schemas_.end()) return it->second;
  std::uint16_t id = 0;
  if (name == kCompressedImageSchema) {
    id = writer_->add_schema(std::string(name), "ros2msg", view(kCompressedImageMsg));
  } else if (name == kCameraTruthSchema) {
    id = writer_->add_schema(std::string(name), "jsonschema", view(kCameraTruthJsonSchema));
  } else {
    id = writer_->add_schema(std::string(name), "omgidl", view(fillet_line_idl()));
  }
  schemas_.emplace(std::string(name), id);
  return id;
}

void RecordingWriter::add_camera(CameraId camera,
                                 const std::optional<BeltCalibration>& calibration) {
  const std::size_t c = index(camera);
  if (estimates_channel_[c] != 0) {
    throw std::logic_error("camera " + std::string(camera_name(camera)) + " added twice");
  }
  const std::map<std::string, std::string> metadata = {{"camera", std::string(camera_name(camera))},
                                                       {"camera_id", std::to_string(c)}};
  estimates_channel_[c] = writer_->add_channel(schema(kCameraEstimatesSchema),
                                               estimates_topic(camera), "cdr", metadata);
  if (!calibration) return;
  image_channel_[c] =
      writer_->add_channel(schema(kCompressedImageSchema), image_topic(camera), "cdr", metadata);
  const std::string yaml = calibration_yaml(*calibration);
  mcap::Attachment attachment;
  attachment.name = calibration_attachment(camera);
  attachment.media_type = "application/yaml";
  attachment.data.assign(yaml.begin(), yaml.end());
  writer_->write_attachment(attachment);
}

void RecordingWriter::attach_line_config(const std::string& yaml_text) {
  mcap::Attachment attachment;
  attachment.name = std::string(kLineConfigAttachment);
  attachment.media_type = "application/yaml";
  attachment.data.assign(yaml_text.begin(), yaml_text.end());
  writer_->write_attachment(attachment);
}

void RecordingWriter::write(std::uint16_t channel, std::uint32_t sequence, std::int64_t log_time_ns,
                            const Bytes& data) {
  if (log_time_ns < 0) throw std::invalid_argument("negative log time " + seconds(log_time_ns));
  const auto time = static_cast<mcap::Timestamp>(log_time_ns);
  writer_->write_message({channel, sequence, time, time, data});
}

void RecordingWriter::write_frame(CameraId camera, std::uint32_t sequence, std::int64_t exposure_ns,
                                  const cv::Mat& image) {
  const std::uint16_t channel = image_channel_.at(index(camera));
  if (channel == 0) {
    throw std::logic_error("camera " + std::string(camera_name(camera)) +
                           " was added without a calibration: it records no frames");
  }
  if (image.empty() || image.depth() != CV_8U || (image.channels() != 3 && image.channels() != 1)) {
    throw std::invalid_argument("frame " + std::to_string(sequence) + " of camera " +
                                std::string(camera_name(camera)) +
                                ": not an 8-bit BGR or grey image");
  }
  if (!cv::imencode(".png", image, png_,
                    {cv::IMWRITE_PNG_COMPRESSION, settings_.png_compression})) {
    throw std::runtime_error("frame " + std::to_string(sequence) + ": PNG encoding failed");
  }
  CompressedImageSample sample;
  sample.stamp_sec = static_cast<std::int32_t>(exposure_ns / kNsPerS);
  sample.stamp_nanosec = static_cast<std::uint32_t>(exposure_ns % kNsPerS);
  sample.frame_id = std::string(camera_name(camera));
  sample.format = "png";
  sample.data.assign(png_.begin(), png_.end());
  write(channel, sequence, exposure_ns, encode(sample));
  ++frames_written_;
  frame_bytes_ += png_.size();
}

void RecordingWriter::write_estimates(CameraId camera, std::int64_t log_time_ns,
                                      const CameraFrame& frame) {
  const std::size_t c = index(camera);
  if (estimates_channel_.at(c) == 0) {
    throw std::logic_error("camera " + std::string(camera_name(camera)) + " was not added");
  }
  write(estimates_channel_[c], estimates_sequence_[c]++, log_time_ns,
        encode(CameraEstimatesSample{static_cast<std::uint8_t>(c), frame}));
}

void RecordingWriter::write_truth(CameraId camera, std::uint32_t sequence, std::int64_t exposure_ns,
                                  const std::vector<TrueFillet>& fillets) {
  const std::size_t c = index(camera);
  if (image_channel_.at(c) == 0) {
    throw std::logic_error("camera " + std::string(camera_name(camera)) +
                           " records no frames: it has no truth to record");
  }
  if (truth_channel_[c] == 0) {
    truth_channel_[c] = writer_->add_channel(
        schema(kCameraTruthSchema), truth_topic(camera), "json",
        {{"camera", std::string(camera_name(camera))}, {"camera_id", std::to_string(c)}});
  }
  nlohmann::json list = nlohmann::json::array();
  for (const TrueFillet& fillet : fillets) {
    list.push_back({{"x_mm", fillet.x_mm},
                    {"y_mm", fillet.y_mm},
                    {"angle_rad", fillet.angle_rad},
                    {"hand", to_string(fillet.hand)},
                    {"side", to_string(fillet.side)},
                    {"group_id", fillet.group_id},
                    {"singulated", fillet.singulated},
                    {"fully_visible", fillet.fully_visible}});
    // JSON has no infinity: a fillet with no neighbour has no gap written.
    if (std::isfinite(fillet.gap_mm)) list.back()["gap_mm"] = fillet.gap_mm;
  }
  const std::string text = nlohmann::json{
      {"camera", camera_name(camera)},
      {"sequence", sequence},
      {"exposure_ns", exposure_ns},
      {"fillets", list}}.dump();
  write(truth_channel_[c], sequence, exposure_ns, Bytes(text.begin(), text.end()));
}

void RecordingWriter::write_scan(std::uint64_t scan, const InputImage& in, const OutputImage& out) {
  const std::uint32_t sequence = scan_sequence_++;
  write(sensors_channel_, sequence, in.time_ns, encode(LineSensorsSample{scan, in}));
  for (std::size_t d = 0; d < kDriveCount; ++d) {
    write(drive_channel_, sequence, in.time_ns,
          encode(DriveFeedbackSample{static_cast<std::uint8_t>(d), in.time_ns, in.drives[d]}));
  }
  write(command_channel_, sequence, in.time_ns, encode(LineCommandSample{in.time_ns, scan, out}));
  LineStatusSample status;
  status.time_ns = in.time_ns;
  status.state = out.state;
  status.active_faults = out.active_faults;
  status.scans = scan + 1;
  status.commands_published = scan + 1;
  write(status_channel_, sequence, in.time_ns, encode(status));
}

void RecordingWriter::close() { writer_->close(); }

std::uint64_t RecordingWriter::bytes_written() const { return writer_->bytes_written(); }

// ------------------------------------------------------------------ reading

namespace {

enum class Kind { kImage, kEstimates, kTruth, kSensors, kDrive, kCommand, kStatus };

struct ChannelInfo {
  Kind kind = Kind::kImage;
  CameraId camera = CameraId::kOrientation;
  std::string topic;
};

std::string describe(const mcap::Message& message, const std::string& topic) {
  return topic + " message " + std::to_string(message.sequence) + " (log time " +
         seconds(static_cast<std::int64_t>(message.log_time)) + ")";
}

ChannelInfo classify(const mcap::Channel& channel, const mcap::Schema* schema,
                     const std::string& file) {
  const std::string where =
      file + ": channel '" + channel.topic + "' (id " + std::to_string(channel.id) + ")";
  if (schema == nullptr) throw RecordingError(where + " has no schema");
  for (std::size_t c = 0; c < kCameraCount; ++c) {
    const auto camera = static_cast<CameraId>(c);
    if (channel.topic != truth_topic(camera)) continue;
    if (channel.message_encoding != "json" || schema->name != kCameraTruthSchema ||
        schema->encoding != "jsonschema") {
      throw RecordingError(where + ": encoding '" + channel.message_encoding + "', schema '" +
                           schema->name + "' (" + schema->encoding + "), expected json, '" +
                           std::string(kCameraTruthSchema) + "' (jsonschema)");
    }
    return {Kind::kTruth, camera, channel.topic};
  }
  if (channel.message_encoding != "cdr") {
    throw RecordingError(where + ": message encoding '" + channel.message_encoding +
                         "', expected cdr");
  }
  const auto expect = [&](std::string_view name, std::string_view encoding) {
    if (schema->name != name || schema->encoding != encoding) {
      throw RecordingError(where + ": schema '" + schema->name + "' (" + schema->encoding +
                           "), expected '" + std::string(name) + "' (" + std::string(encoding) +
                           ")");
    }
  };
  ChannelInfo info;
  info.topic = channel.topic;
  for (std::size_t c = 0; c < kCameraCount; ++c) {
    const auto camera = static_cast<CameraId>(c);
    if (channel.topic == image_topic(camera)) {
      expect(kCompressedImageSchema, "ros2msg");
      return {Kind::kImage, camera, channel.topic};
    }
    if (channel.topic == estimates_topic(camera)) {
      expect(kCameraEstimatesSchema, "omgidl");
      return {Kind::kEstimates, camera, channel.topic};
    }
  }
  if (channel.topic == kSensorsTopic) {
    expect(kLineSensorsSchema, "omgidl");
    info.kind = Kind::kSensors;
  } else if (channel.topic == kDriveFeedbackTopic) {
    expect(kDriveFeedbackSchema, "omgidl");
    info.kind = Kind::kDrive;
  } else if (channel.topic == kCommandTopic) {
    expect(kLineCommandSchema, "omgidl");
    info.kind = Kind::kCommand;
  } else if (channel.topic == kStatusTopic) {
    expect(kLineStatusSchema, "omgidl");
    info.kind = Kind::kStatus;
  } else {
    throw RecordingError(where + ": unknown channel with schema '" + schema->name + "' (" +
                         schema->encoding +
                         "); a recording holds only the channels of docs/vision.md");
  }
  return info;
}

// Where a JSON text stops parsing, as a field path ("fillets[2].x_mm"): a SAX pass that builds
// nothing, run only on a message that does not parse, so that the error names the field.
class JsonErrorPath final : public nlohmann::json_sax<nlohmann::json> {
 public:
  bool null() override { return value(); }
  bool boolean(bool /*value*/) override { return value(); }
  bool number_integer(number_integer_t /*value*/) override { return value(); }
  bool number_unsigned(number_unsigned_t /*value*/) override { return value(); }
  bool number_float(number_float_t /*value*/, const string_t& /*text*/) override { return value(); }
  bool string(string_t& /*value*/) override { return value(); }
  bool binary(binary_t& /*value*/) override { return value(); }
  bool start_object(std::size_t /*elements*/) override {
    levels_.push_back({false, 0, {}});
    return true;
  }
  bool key(string_t& name) override {
    levels_.back().key = name;
    return true;
  }
  bool end_object() override {
    levels_.pop_back();
    return value();
  }
  bool start_array(std::size_t /*elements*/) override {
    levels_.push_back({true, 0, {}});
    return true;
  }
  bool end_array() override {
    levels_.pop_back();
    return value();
  }
  bool parse_error(std::size_t position, const std::string& /*token*/,
                   const nlohmann::detail::exception& error) override {
    std::string reason = error.what();  // "[json.exception.parse_error.101] parse error at ..."
    if (const auto end = reason.find("] "); end != std::string::npos) reason.erase(0, end + 2);
    error_ = "byte " + std::to_string(position) + ", at " + path() + ": " + reason;
    return false;
  }

  // "byte 57, at fillets[0].x_mm: number overflow parsing '1e999'".
  [[nodiscard]] const std::string& error() const { return error_; }

 private:
  struct Level {
    bool array = false;
    std::size_t index = 0;  // arrays: the element being parsed
    std::string key;        // objects: the member being parsed
  };

  bool value() {
    if (!levels_.empty() && levels_.back().array) ++levels_.back().index;
    return true;
  }

  [[nodiscard]] std::string path() const {
    std::string text;
    for (const Level& level : levels_) {
      if (level.array) {
        text += "[" + std::to_string(level.index) + "]";
      } else if (!level.key.empty()) {
        text += (text.empty() ? "" : ".") + level.key;
      }
    }
    return text.empty() ? "the top level" : text;
  }

  std::vector<Level> levels_;
  std::string error_;
};

// One truth message of `camera`'s truth channel, MCAP sequence `sequence` at `log_time_ns`;
// RecordingError naming `where` and the field when it is malformed. The message's own camera,
// sequence and exposure_ns, where given, must agree with the channel and the MCAP record.
std::vector<TrueFillet> decode_truth(const Bytes& data, const std::string& where, CameraId camera,
                                     std::uint32_t sequence, std::int64_t log_time_ns) {
  const nlohmann::json json = nlohmann::json::parse(data.begin(), data.end(), nullptr, false);
  if (json.is_discarded()) {
    JsonErrorPath sax;
    (void)nlohmann::json::sax_parse(data.begin(), data.end(), &sax);
    throw RecordingError(where + ": not a truth message, not JSON (" + sax.error() + ")");
  }
  if (!json.is_object() || !json.contains("fillets") || !json["fillets"].is_array()) {
    throw RecordingError(where + ": not a truth message (a JSON object with a 'fillets' array): " +
                         (json.is_object() ? (json.contains("fillets") ? "'fillets' is not an array"
                                                                       : "no 'fillets'")
                                           : "not an object"));
  }
  // The header fields are redundant with the channel and the MCAP record; a disagreement means
  // a damaged or hand-made file, and which one is right would be a guess.
  if (json.contains("camera") &&
      (!json["camera"].is_string() || json["camera"].get<std::string>() != camera_name(camera))) {
    throw RecordingError(where + ": camera: " + json["camera"].dump() +
                         " on the channel of camera " + std::string(camera_name(camera)));
  }
  if (json.contains("sequence") && json["sequence"] != nlohmann::json(sequence)) {
    throw RecordingError(where + ": sequence: " + json["sequence"].dump() +
                         " in a message recorded as the truth of frame " +
                         std::to_string(sequence));
  }
  if (json.contains("exposure_ns") && json["exposure_ns"] != nlohmann::json(log_time_ns)) {
    throw RecordingError(where + ": exposure_ns: " + json["exposure_ns"].dump() +
                         " in a message logged at " + std::to_string(log_time_ns) + " ns");
  }
  std::vector<TrueFillet> fillets;
  for (std::size_t i = 0; i < json["fillets"].size(); ++i) {
    const nlohmann::json& item = json["fillets"][i];
    const std::string at = where + ": fillets[" + std::to_string(i) + "]";
    if (!item.is_object()) throw RecordingError(at + ": " + item.dump() + " is not an object");
    const auto field = [&](const char* key) -> const nlohmann::json& {
      if (!item.contains(key)) throw RecordingError(at + "." + key + ": missing");
      return item[key];
    };
    const auto number = [&](const char* key) {
      const nlohmann::json& value = field(key);
      if (value.is_null()) {
        // nlohmann::json writes a NaN or an infinity as null.
        throw RecordingError(at + "." + key + ": null, not a number (a non-finite value?)");
      }
      if (!value.is_number()) {
        throw RecordingError(at + "." + key + ": " + value.dump() + " is not a number");
      }
      const double number_value = value.get<double>();
      if (!std::isfinite(number_value)) throw RecordingError(at + "." + key + ": not finite");
      return number_value;
    };
    const auto flag = [&](const char* key) {
      const nlohmann::json& value = field(key);
      if (!value.is_boolean()) {
        throw RecordingError(at + "." + key + ": " + value.dump() + " is not true or false");
      }
      return value.get<bool>();
    };
    const auto name = [&](const char* key) {
      const nlohmann::json& value = field(key);
      if (!value.is_string()) {
        throw RecordingError(at + "." + key + ": " + value.dump() + " is not a string");
      }
      return value.get<std::string>();
    };
    TrueFillet fillet;
    fillet.x_mm = number("x_mm");
    fillet.y_mm = number("y_mm");
    fillet.angle_rad = number("angle_rad");
    const std::string hand_name = name("hand");
    const std::optional<Hand> hand = parse<Hand>(hand_name);
    if (!hand || *hand == Hand::kUnknown) {
      throw RecordingError(at + ".hand: '" + hand_name + "' is not left or right");
    }
    const std::string side_name = name("side");
    const std::optional<SideUp> side = parse<SideUp>(side_name);
    if (!side || *side == SideUp::kUnknown) {
      throw RecordingError(at + ".side: '" + side_name + "' is not skin or bone");
    }
    fillet.hand = *hand;
    fillet.side = *side;
    // A whole number in int's range: casting any other double to int is undefined.
    const double group_id = number("group_id");
    if (group_id != std::floor(group_id) || group_id < -1.0 ||
        group_id > static_cast<double>(std::numeric_limits<int>::max())) {
      throw RecordingError(at + ".group_id: " + item["group_id"].dump() +
                           " is not -1 or a whole number from 0 to " +
                           std::to_string(std::numeric_limits<int>::max()));
    }
    fillet.group_id = static_cast<int>(group_id);
    fillet.singulated = flag("singulated");
    fillet.fully_visible = flag("fully_visible");
    // Optional (recordings before it have none): no neighbour, as the writer leaves it out.
    if (item.contains("gap_mm")) {
      fillet.gap_mm = number("gap_mm");
      if (fillet.gap_mm < 0.0) {
        throw RecordingError(at + ".gap_mm: " + item["gap_mm"].dump() + " is negative");
      }
    }
    fillets.push_back(fillet);
  }
  return fillets;
}

}  // namespace

Recording load_recording(const std::filesystem::path& path) {
  const std::string file = path.string();
  if (!std::filesystem::is_regular_file(path)) {
    throw RecordingError(file + ": no such recording (not a regular file)");
  }
  Recording recording;
  recording.path = path;
  std::vector<mcap::Message> messages;
  std::map<std::uint16_t, ChannelInfo> channels;
  try {
    mcap::Reader reader = mcap::Reader::open(path);
    const mcap::Summary& summary = reader.summary();
    for (const auto& [id, channel] : summary.channels) {
      const auto schema = summary.schemas.find(channel.schema_id);
      channels.emplace(
          id, classify(channel, schema == summary.schemas.end() ? nullptr : &schema->second, file));
    }
    for (const mcap::AttachmentIndex& index : summary.attachment_indexes) {
      const mcap::Attachment attachment = reader.read_attachment(index);
      const std::string text(attachment.data.begin(), attachment.data.end());
      if (attachment.name == kLineConfigAttachment) {
        recording.line_config_yaml = text;
        continue;
      }
      for (std::size_t c = 0; c < kCameraCount; ++c) {
        const auto camera = static_cast<CameraId>(c);
        if (attachment.name != calibration_attachment(camera)) continue;
        try {
          recording.cameras[c].calibration =
              parse_calibration(text, file + ": attachment " + attachment.name);
        } catch (const std::exception& error) {
          throw RecordingError(file + ": attachment " + attachment.name +
                               " is not a valid calibration: " + error.what());
        }
      }
    }
    for (const mcap::MetadataIndex& index : summary.metadata_indexes) {
      const mcap::Metadata metadata = reader.read_metadata(index);
      if (metadata.name == kInfoMetadataName) recording.info = metadata.metadata;
    }
    messages = reader.read_messages();
  } catch (const mcap::Error& error) {
    throw RecordingError(file + ": not a readable MCAP recording: " + error.what());
  } catch (const RecordingError&) {
    throw;
  } catch (const std::exception& error) {
    throw RecordingError(file + ": " + error.what());
  }
  if (const auto version = recording.info.find("format_version");
      version != recording.info.end() && version->second != kRecordingFormatVersion) {
    throw RecordingError(file + ": recording format version " + version->second +
                         ", this linectl reads version " + std::string(kRecordingFormatVersion));
  }
  for (const auto& [id, channel] : channels) {
    if (channel.kind == Kind::kImage) recording.cameras[index(channel.camera)].has_frames = true;
  }
  for (std::size_t c = 0; c < kCameraCount; ++c) {
    if (recording.cameras[c].has_frames && !recording.cameras[c].calibration) {
      throw RecordingError(file + ": camera " + std::string(to_string(static_cast<CameraId>(c))) +
                           " has frames but no attachment " +
                           calibration_attachment(static_cast<CameraId>(c)));
    }
  }

  recording.message_count = messages.size();
  std::map<std::int64_t, std::size_t> scan_at_time;
  std::map<std::int64_t, std::set<std::uint8_t>> drives_at_time;
  const auto scan_for = [&](std::int64_t time_ns, const std::string& where) -> RecordedScan& {
    const auto it = scan_at_time.find(time_ns);
    if (it == scan_at_time.end()) {
      throw RecordingError(file + ": " + where + " has no /line/sensors sample at its time");
    }
    return recording.scans[it->second];
  };
  for (const mcap::Message& message : messages) {
    const auto channel_it = channels.find(message.channel_id);
    if (channel_it == channels.end()) {
      throw RecordingError(file + ": message " + std::to_string(message.sequence) +
                           " on unknown channel id " + std::to_string(message.channel_id));
    }
    const ChannelInfo& channel = channel_it->second;
    const std::string where = describe(message, channel.topic);
    const auto log_time_ns = static_cast<std::int64_t>(message.log_time);
    try {
      switch (channel.kind) {
        case Kind::kImage: {
          CompressedImageSample sample = decode_compressed_image(message.data);
          RecordedFrame frame;
          frame.sequence = message.sequence;
          frame.exposure_ns = log_time_ns;
          frame.format = sample.format;
          frame.data = std::move(sample.data);
          frame.where = file + ": " + where;
          if (frame.format != "png") {
            throw RecordingError(frame.where + ": image format '" + frame.format +
                                 "', expected png (lossless)");
          }
          auto& frames = recording.cameras[index(channel.camera)].frames;
          if (!frames.emplace(frame.sequence, std::move(frame)).second) {
            throw RecordingError(file + ": " + where + ": frame sequence recorded twice");
          }
          break;
        }
        case Kind::kEstimates: {
          const CameraEstimatesSample sample = decode_camera_estimates(message.data);
          if (sample.camera_id != index(channel.camera)) {
            throw RecordingError(file + ": " + where + ": camera_id " +
                                 std::to_string(sample.camera_id) + " on the channel of camera " +
                                 std::to_string(index(channel.camera)));
          }
          recording.estimates.push_back(
              {channel.camera, log_time_ns, sample.frame, file + ": " + where});
          break;
        }
        case Kind::kTruth: {
          auto& truth = recording.cameras[index(channel.camera)].truth;
          if (!truth
                   .emplace(message.sequence,
                            decode_truth(message.data, file + ": " + where, channel.camera,
                                         message.sequence, log_time_ns))
                   .second) {
            throw RecordingError(file + ": " + where + ": truth of a frame recorded twice");
          }
          break;
        }
        case Kind::kSensors: {
          const LineSensorsSample sample = decode_line_sensors(message.data);
          if (sample.scan != recording.scans.size() || sample.input.time_ns != log_time_ns) {
            throw RecordingError(file + ": " + where + ": scan " + std::to_string(sample.scan) +
                                 " at " + seconds(sample.input.time_ns) + ", expected scan " +
                                 std::to_string(recording.scans.size()) + " at the log time");
          }
          scan_at_time[log_time_ns] = recording.scans.size();
          recording.scans.push_back({sample.scan, sample.input, std::nullopt});
          break;
        }
        case Kind::kDrive: {
          const DriveFeedbackSample sample = decode_drive_feedback(message.data);
          RecordedScan& scan = scan_for(log_time_ns, where);
          scan.input.drives[sample.drive_id] = sample.feedback;
          drives_at_time[log_time_ns].insert(sample.drive_id);
          break;
        }
        case Kind::kCommand: {
          const LineCommandSample sample = decode_line_command(message.data);
          RecordedScan& scan = scan_for(log_time_ns, where);
          OutputImage out = sample.output;
          if (scan.recorded_output) {
            out.state = scan.recorded_output->state;
            out.active_faults = scan.recorded_output->active_faults;
          }
          scan.recorded_output = out;
          break;
        }
        case Kind::kStatus: {
          const LineStatusSample sample = decode_line_status(message.data);
          RecordedScan& scan = scan_for(log_time_ns, where);
          if (!scan.recorded_output) scan.recorded_output = OutputImage{};
          scan.recorded_output->state = sample.state;
          scan.recorded_output->active_faults = sample.active_faults;
          break;
        }
      }
    } catch (const CdrError& error) {
      throw RecordingError(file + ": " + where + ": sample does not decode: " + error.what());
    }
  }
  for (const RecordedScan& scan : recording.scans) {
    if (drives_at_time[scan.input.time_ns].size() != kDriveCount) {
      throw RecordingError(file + ": scan " + std::to_string(scan.scan) + " (" +
                           seconds(scan.input.time_ns) + ") has drive feedback for " +
                           std::to_string(drives_at_time[scan.input.time_ns].size()) + " of " +
                           std::to_string(kDriveCount) + " drives");
    }
  }
  return recording;
}

cv::Mat decode_frame(const RecordedFrame& frame) {
  cv::Mat image;
  if (!frame.data.empty()) {
    std::optional<cv::Mat> fast = detail::decode_png_fast(frame.data);
    image = fast ? std::move(*fast) : cv::imdecode(frame.data, cv::IMREAD_UNCHANGED);
  }
  if (image.empty()) {
    throw RecordingError(frame.where + ": PNG data (" + std::to_string(frame.data.size()) +
                         " bytes) does not decode");
  }
  if (image.depth() != CV_8U) {
    throw RecordingError(frame.where + ": PNG is not 8-bit");
  }
  if (image.channels() == 1) {
    cv::Mat bgr;
    cv::cvtColor(image, bgr, cv::COLOR_GRAY2BGR);
    return bgr;
  }
  if (image.channels() == 4) {
    cv::Mat bgr;
    cv::cvtColor(image, bgr, cv::COLOR_BGRA2BGR);
    return bgr;
  }
  return image;
}

void join_frames(Recording& line, const Recording& frames) {
  const std::string files = line.path.string() + " and " + frames.path.string();
  for (std::size_t c = 0; c < kCameraCount; ++c) {
    const RecordedCamera& camera = frames.cameras[c];
    if (!camera.has_frames) continue;
    const std::string name(camera_name(static_cast<CameraId>(c)));
    if (line.cameras[c].has_frames) {
      throw RecordingError(files + ": both hold frames of camera " + name);
    }
    for (const RecordedEstimates& estimates : line.estimates) {
      if (index(estimates.camera) == c && estimates.frame.sequence != 0 &&
          camera.frames.count(estimates.frame.sequence) == 0) {
        throw RecordingError(files + ": " + estimates.where + " names frame " +
                             std::to_string(estimates.frame.sequence) + " of camera " + name +
                             ", which " + frames.path.string() +
                             " does not hold (another run or another camera?)");
      }
    }
    line.cameras[c] = camera;
  }
}

}  // namespace fl::vision::record
