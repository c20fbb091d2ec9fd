#include "fl/vision/record/cdr.hpp"

#include <bit>
#include <cstring>
#include <limits>

namespace fl::vision::record {
namespace {

// CDR_LE representation identifier and zero options: what Cyclone (XCDR1, little-endian host)
// and ROS 2 write.
constexpr std::uint8_t kEncapsulationHeader[4] = {0x00, 0x01, 0x00, 0x00};
constexpr std::size_t kHeaderBytes = 4;
// Enum counts of the IDL types (fillet_line.idl): Hand, SideUp, LineState.
constexpr std::uint32_t kHandCount = 3;
constexpr std::uint32_t kSideCount = 3;
constexpr std::uint32_t kLineStateCount = 5;

void write_estimate(CdrWriter& w, const FilletEstimate& e) {
  w.write_f32(e.x_mm);
  w.write_f32(e.y_mm);
  w.write_f32(e.angle_rad);
  w.write_f32(e.confidence);
  w.write_u32(static_cast<std::uint32_t>(e.hand));
  w.write_u32(static_cast<std::uint32_t>(e.side));
  w.write_bool(e.singulated);
}

FilletEstimate read_estimate(CdrReader& r) {
  FilletEstimate e;
  e.x_mm = r.read_f32("estimates[].x_mm");
  e.y_mm = r.read_f32("estimates[].y_mm");
  e.angle_rad = r.read_f32("estimates[].angle_rad");
  e.confidence = r.read_f32("estimates[].confidence");
  e.hand = static_cast<Hand>(r.read_enum("estimates[].hand", kHandCount));
  e.side = static_cast<SideUp>(r.read_enum("estimates[].side", kSideCount));
  e.singulated = r.read_bool("estimates[].singulated");
  return e;
}

}  // namespace

// ------------------------------------------------------------------ writer

CdrWriter::CdrWriter() {
  bytes_.reserve(64);
  bytes_.insert(bytes_.end(), std::begin(kEncapsulationHeader), std::end(kEncapsulationHeader));
}

void CdrWriter::align(std::size_t alignment) {
  while ((bytes_.size() - kHeaderBytes) % alignment != 0) bytes_.push_back(0);
}

Bytes CdrWriter::take() {
  const std::size_t padding = (4 - bytes_.size() % 4) % 4;
  bytes_.insert(bytes_.end(), padding, 0);
  bytes_[3] = static_cast<std::uint8_t>(padding);
  return std::move(bytes_);
}

void CdrWriter::write_u32(std::uint32_t value) {
  align(4);
  for (int shift = 0; shift < 32; shift += 8) {
    bytes_.push_back(static_cast<std::uint8_t>(value >> shift));
  }
}

void CdrWriter::write_u64(std::uint64_t value) {
  align(8);
  for (int shift = 0; shift < 64; shift += 8) {
    bytes_.push_back(static_cast<std::uint8_t>(value >> shift));
  }
}

void CdrWriter::write_f32(float value) { write_u32(std::bit_cast<std::uint32_t>(value)); }

void CdrWriter::write_string(std::string_view value) {
  write_u32(static_cast<std::uint32_t>(value.size() + 1));
  bytes_.insert(bytes_.end(), value.begin(), value.end());
  bytes_.push_back(0);
}

void CdrWriter::write_octet_sequence(ByteView value) {
  write_u32(static_cast<std::uint32_t>(value.size()));
  bytes_.insert(bytes_.end(), value.begin(), value.end());
}

// ------------------------------------------------------------------ reader

CdrReader::CdrReader(ByteView bytes, std::string type_name)
    : bytes_(bytes), type_name_(std::move(type_name)) {
  if (bytes_.size() < kHeaderBytes) {
    throw CdrError(type_name_ + ": " + std::to_string(bytes_.size()) +
                   " bytes, shorter than the 4-byte CDR encapsulation header");
  }
  if (bytes_[0] != kEncapsulationHeader[0] || bytes_[1] != kEncapsulationHeader[1]) {
    throw CdrError(type_name_ + ": encapsulation " + std::to_string(bytes_[0]) + "," +
                   std::to_string(bytes_[1]) +
                   " is not CDR_LE (0,1); only little-endian plain CDR is read");
  }
}

void CdrReader::fail(const char* member, const std::string& why) const {
  throw CdrError(type_name_ + "." + member + " at byte " + std::to_string(position_) + ": " + why);
}

void CdrReader::align(std::size_t alignment, const char* member) {
  const std::size_t misalignment = (position_ - kHeaderBytes) % alignment;
  if (misalignment != 0) take(alignment - misalignment, member);
}

const std::uint8_t* CdrReader::take(std::size_t count, const char* member) {
  if (count > bytes_.size() - position_) {
    fail(member, "needs " + std::to_string(count) + " bytes, " +
                     std::to_string(bytes_.size() - position_) + " left (truncated sample)");
  }
  const std::uint8_t* data = bytes_.data() + position_;
  position_ += count;
  return data;
}

std::uint8_t CdrReader::read_u8(const char* member) { return *take(1, member); }

bool CdrReader::read_bool(const char* member) {
  const std::uint8_t value = *take(1, member);
  if (value > 1) fail(member, "boolean byte " + std::to_string(value) + " is neither 0 nor 1");
  return value == 1;
}

std::uint32_t CdrReader::read_u32(const char* member) {
  align(4, member);
  const std::uint8_t* p = take(4, member);
  std::uint32_t value = 0;
  for (int i = 3; i >= 0; --i) value = (value << 8) | p[i];
  return value;
}

std::uint64_t CdrReader::read_u64(const char* member) {
  align(8, member);
  const std::uint8_t* p = take(8, member);
  std::uint64_t value = 0;
  for (int i = 7; i >= 0; --i) value = (value << 8) | p[i];
  return value;
}

float CdrReader::read_f32(const char* member) { return std::bit_cast<float>(read_u32(member)); }

std::uint32_t CdrReader::read_enum(const char* member, std::uint32_t count) {
  const std::uint32_t value = read_u32(member);
  if (value >= count) {
    fail(member,
         "enum value " + std::to_string(value) + " outside 0.." + std::to_string(count - 1));
  }
  return value;
}

std::string CdrReader::read_string(const char* member) {
  const std::uint32_t length = read_u32(member);
  if (length == 0) fail(member, "string length 0 (CDR strings count their NUL)");
  const std::uint8_t* p = take(length, member);
  if (p[length - 1] != 0) fail(member, "string is not NUL-terminated");
  return {reinterpret_cast<const char*>(p), length - 1};
}

Bytes CdrReader::read_octet_sequence(const char* member) {
  const std::uint32_t length = read_u32(member);
  const std::uint8_t* p = take(length, member);
  return {p, p + length};
}

void CdrReader::finish() {
  const std::size_t left = bytes_.size() - position_;
  if (left > 3) fail("<end>", std::to_string(left) + " bytes after the last member");
}

// ------------------------------------------------------------------ types

Bytes encode(const CameraEstimatesSample& sample) {
  CdrWriter w;
  w.write_u8(sample.camera_id);
  w.write_i64(sample.frame.frame_time_ns);
  w.write_u32(sample.frame.sequence);
  w.write_u8(sample.frame.count);
  for (const FilletEstimate& e : sample.frame.estimates) write_estimate(w, e);
  return w.take();
}

CameraEstimatesSample decode_camera_estimates(ByteView bytes) {
  CdrReader r(bytes, "fl::CameraEstimates");
  CameraEstimatesSample sample;
  sample.camera_id = r.read_u8("camera_id");
  if (sample.camera_id >= kCameraCount) {
    throw CdrError("fl::CameraEstimates.camera_id " + std::to_string(sample.camera_id) +
                   " outside 0.." + std::to_string(kCameraCount - 1));
  }
  sample.frame.frame_time_ns = r.read_i64("frame_time_ns");
  sample.frame.sequence = r.read_u32("frame_sequence");
  sample.frame.count = r.read_u8("count");
  if (sample.frame.count > kMaxEstimatesPerFrame) {
    throw CdrError("fl::CameraEstimates.count " + std::to_string(sample.frame.count) +
                   " above MAX_ESTIMATES_PER_FRAME " + std::to_string(kMaxEstimatesPerFrame));
  }
  for (FilletEstimate& e : sample.frame.estimates) e = read_estimate(r);
  r.finish();
  return sample;
}

Bytes encode(const LineCommandSample& sample) {
  CdrWriter w;
  w.write_i64(sample.time_ns);
  w.write_u64(sample.scan);
  for (const DriveCommand& drive : sample.output.drives) {
    w.write_bool(drive.enable);
    w.write_f32(drive.speed_mps);
    w.write_f32(drive.accel_mps2);
  }
  const OutputImage& out = sample.output;
  w.write_f32(out.hopper_opening_mm);
  w.write_f32(out.leveller_speed_rpm);
  w.write_bool(out.flip_plate1_flip);
  w.write_bool(out.flip_plate2_flip);
  w.write_f32(out.centring_shift_mm);
  w.write_bool(out.centring_stroke);
  w.write_bool(out.squeeze_roller_down);
  w.write_bool(out.final_reject);
  return w.take();
}

LineCommandSample decode_line_command(ByteView bytes) {
  CdrReader r(bytes, "fl::LineCommand");
  LineCommandSample sample;
  sample.time_ns = r.read_i64("time_ns");
  sample.scan = r.read_u64("scan");
  for (DriveCommand& drive : sample.output.drives) {
    drive.enable = r.read_bool("drives[].enable");
    drive.speed_mps = r.read_f32("drives[].speed_mps");
    drive.accel_mps2 = r.read_f32("drives[].accel_mps2");
  }
  OutputImage& out = sample.output;
  out.hopper_opening_mm = r.read_f32("hopper_opening_mm");
  out.leveller_speed_rpm = r.read_f32("leveller_speed_rpm");
  out.flip_plate1_flip = r.read_bool("flip_plate1_flip");
  out.flip_plate2_flip = r.read_bool("flip_plate2_flip");
  out.centring_shift_mm = r.read_f32("centring_shift_mm");
  out.centring_stroke = r.read_bool("centring_stroke");
  out.squeeze_roller_down = r.read_bool("squeeze_roller_down");
  out.final_reject = r.read_bool("final_reject");
  r.finish();
  return sample;
}

Bytes encode(const LineStatusSample& sample) {
  CdrWriter w;
  w.write_i64(sample.time_ns);
  w.write_u32(static_cast<std::uint32_t>(sample.state));
  w.write_u32(sample.active_faults);
  w.write_u64(sample.scans);
  w.write_u64(sample.commands_published);
  w.write_u64(sample.commands_dropped);
  w.write_u32(sample.camera_stale_mask);
  w.write_u64(sample.estimates_rejected_transport);
  return w.take();
}

LineStatusSample decode_line_status(ByteView bytes) {
  CdrReader r(bytes, "fl::LineStatus");
  LineStatusSample sample;
  sample.time_ns = r.read_i64("time_ns");
  sample.state = static_cast<LineState>(r.read_enum("state", kLineStateCount));
  sample.active_faults = r.read_u32("active_faults");
  sample.scans = r.read_u64("scans");
  sample.commands_published = r.read_u64("commands_published");
  sample.commands_dropped = r.read_u64("commands_dropped");
  sample.camera_stale_mask = r.read_u32("camera_stale_mask");
  sample.estimates_rejected_transport = r.read_u64("estimates_rejected_transport");
  r.finish();
  return sample;
}

Bytes encode(const DriveFeedbackSample& sample) {
  CdrWriter w;
  w.write_u8(sample.drive_id);
  w.write_i64(sample.time_ns);
  w.write_f32(sample.feedback.speed_mps);
  w.write_i64(sample.feedback.encoder_counts);
  w.write_bool(sample.feedback.ready);
  w.write_bool(sample.feedback.fault);
  return w.take();
}

DriveFeedbackSample decode_drive_feedback(ByteView bytes) {
  CdrReader r(bytes, "fl::DriveFeedback");
  DriveFeedbackSample sample;
  sample.drive_id = r.read_u8("drive_id");
  if (sample.drive_id >= kDriveCount) {
    throw CdrError("fl::DriveFeedback.drive_id " + std::to_string(sample.drive_id) +
                   " outside 0.." + std::to_string(kDriveCount - 1));
  }
  sample.time_ns = r.read_i64("time_ns");
  sample.feedback.speed_mps = r.read_f32("speed_mps");
  sample.feedback.encoder_counts = r.read_i64("encoder_counts");
  sample.feedback.ready = r.read_bool("ready");
  sample.feedback.fault = r.read_bool("fault");
  r.finish();
  return sample;
}

Bytes encode(const LineSensorsSample& sample) {
  const InputImage& in = sample.input;
  CdrWriter w;
  w.write_i64(in.time_ns);
  w.write_u64(sample.scan);
  w.write_bool(in.takt_beam_broken);
  w.write_f32(in.level_mm);
  w.write_f32(in.hopper_opening_mm);
  w.write_f32(in.leveller_speed_rpm);
  w.write_bool(in.leveller_overload);
  w.write_bool(in.flip_plate1_flipping);
  w.write_bool(in.flip_plate2_flipping);
  w.write_f32(in.centring_position_mm);
  w.write_bool(in.squeeze_roller_down);
  w.write_bool(in.estop_ok);
  w.write_bool(in.start_request);
  w.write_bool(in.stop_request);
  w.write_bool(in.fault_reset_request);
  return w.take();
}

LineSensorsSample decode_line_sensors(ByteView bytes) {
  CdrReader r(bytes, "fl::LineSensors");
  LineSensorsSample sample;
  InputImage& in = sample.input;
  in.time_ns = r.read_i64("time_ns");
  sample.scan = r.read_u64("scan");
  in.takt_beam_broken = r.read_bool("takt_beam_broken");
  in.level_mm = r.read_f32("level_mm");
  in.hopper_opening_mm = r.read_f32("hopper_opening_mm");
  in.leveller_speed_rpm = r.read_f32("leveller_speed_rpm");
  in.leveller_overload = r.read_bool("leveller_overload");
  in.flip_plate1_flipping = r.read_bool("flip_plate1_flipping");
  in.flip_plate2_flipping = r.read_bool("flip_plate2_flipping");
  in.centring_position_mm = r.read_f32("centring_position_mm");
  in.squeeze_roller_down = r.read_bool("squeeze_roller_down");
  in.estop_ok = r.read_bool("estop_ok");
  in.start_request = r.read_bool("start_request");
  in.stop_request = r.read_bool("stop_request");
  in.fault_reset_request = r.read_bool("fault_reset_request");
  r.finish();
  return sample;
}

Bytes encode(const CompressedImageSample& sample) {
  CdrWriter w;
  w.write_i32(sample.stamp_sec);
  w.write_u32(sample.stamp_nanosec);
  w.write_string(sample.frame_id);
  w.write_string(sample.format);
  w.write_octet_sequence(sample.data);
  return w.take();
}

CompressedImageSample decode_compressed_image(ByteView bytes) {
  CdrReader r(bytes, "sensor_msgs/msg/CompressedImage");
  CompressedImageSample sample;
  sample.stamp_sec = r.read_i32("header.stamp.sec");
  sample.stamp_nanosec = r.read_u32("header.stamp.nanosec");
  sample.frame_id = r.read_string("header.frame_id");
  sample.format = r.read_string("format");
  sample.data = r.read_octet_sequence("data");
  r.finish();
  return sample;
}

}  // namespace fl::vision::record
