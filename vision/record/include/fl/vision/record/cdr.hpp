// A small CDR encoder and decoder for the fixed types that recordings carry: the DDS types of
// drivers/dds/idl/fillet_line.idl (CameraEstimates, LineCommand, LineStatus, DriveFeedback,
// LineSensors), and the ROS 2
// sensor_msgs/msg/CompressedImage that carries the PNG frames.
//
// Encoding: plain (XCDR1) CDR, little endian, as Cyclone DDS puts @final structs on the wire
// and as ROS 2 writes its messages: a 4-byte encapsulation header {0x00, 0x01, 0x00, 0x00}
// (CDR_LE), then the members in declaration order, each primitive aligned to its own size
// (8-byte types to 8) counted from the end of the header, enums as 32-bit integers, booleans
// as one byte, fixed arrays without a length, strings and sequences with a uint32 length
// (strings count their terminating NUL), the sample padded to a multiple of 4 with the padding
// count in the options' low two bits. vision/record/tests/cdr_cyclone_test.cpp checks the
// bytes against Cyclone DDS's own serializer.
//
// Decoding checks every length against the bytes present, every enum and boolean against its
// range, and throws CdrError naming the type, the member and the byte offset.
#pragma once

#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "fl/controller/process_image.hpp"

namespace fl::vision::record {

using Bytes = std::vector<std::uint8_t>;
using ByteView = std::span<const std::uint8_t>;

class CdrError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Appends CDR members to a buffer that starts with the CDR_LE encapsulation header.
class CdrWriter {
 public:
  CdrWriter();
  void write_u8(std::uint8_t value) { bytes_.push_back(value); }
  void write_bool(bool value) { bytes_.push_back(value ? 1 : 0); }
  void write_u32(std::uint32_t value);
  void write_i32(std::int32_t value) { write_u32(static_cast<std::uint32_t>(value)); }
  void write_u64(std::uint64_t value);
  void write_i64(std::int64_t value) { write_u64(static_cast<std::uint64_t>(value)); }
  void write_f32(float value);
  void write_string(std::string_view value);
  void write_octet_sequence(ByteView value);
  // Pads the sample to a multiple of 4 bytes and notes the padding in the low two bits of
  // the encapsulation options (DDS-XTypes 7.4.3.5.2), as Cyclone does, and returns it.
  [[nodiscard]] Bytes take();

 private:
  void align(std::size_t alignment);
  Bytes bytes_;
};

// Reads CDR members; every read names the member for the error message.
class CdrReader {
 public:
  // Checks the encapsulation header (CDR_LE only). `type_name` goes into every error.
  CdrReader(ByteView bytes, std::string type_name);
  std::uint8_t read_u8(const char* member);
  bool read_bool(const char* member);
  std::uint32_t read_u32(const char* member);
  std::int32_t read_i32(const char* member) { return static_cast<std::int32_t>(read_u32(member)); }
  std::uint64_t read_u64(const char* member);
  std::int64_t read_i64(const char* member) { return static_cast<std::int64_t>(read_u64(member)); }
  float read_f32(const char* member);
  // An enum member: a 32-bit value that must be below `count`.
  std::uint32_t read_enum(const char* member, std::uint32_t count);
  std::string read_string(const char* member);
  Bytes read_octet_sequence(const char* member);
  // At most 3 bytes of trailing padding may follow the last member (writers may pad the
  // sample to a multiple of 4); anything more is an error.
  void finish();

 private:
  void align(std::size_t alignment, const char* member);
  const std::uint8_t* take(std::size_t count, const char* member);
  [[noreturn]] void fail(const char* member, const std::string& why) const;
  ByteView bytes_;
  std::string type_name_;
  std::size_t position_ = 4;  // after the encapsulation header
};

// ------------------------------------------------------------------ the recorded types

// fl::CameraEstimates: one camera frame's estimates.
struct CameraEstimatesSample {
  std::uint8_t camera_id = 0;  // fl::CameraId
  CameraFrame frame;
};

// fl::LineCommand: the actuator part of an OutputImage (state and faults are LineStatus's).
struct LineCommandSample {
  std::int64_t time_ns = 0;
  std::uint64_t scan = 0;
  OutputImage output;  // state and active_faults are not carried (left default on decode)
};

// fl::LineStatus.
struct LineStatusSample {
  std::int64_t time_ns = 0;
  LineState state = LineState::kStopped;
  std::uint32_t active_faults = 0;
  std::uint64_t scans = 0;
  std::uint64_t commands_published = 0;
  std::uint64_t commands_dropped = 0;
  std::uint32_t camera_stale_mask = 0;
  std::uint64_t estimates_rejected_transport = 0;
};

// fl::DriveFeedback.
struct DriveFeedbackSample {
  std::uint8_t drive_id = 0;  // fl::DriveId
  std::int64_t time_ns = 0;
  DriveFeedback feedback;
};

// fl::LineSensors (fillet_line.idl): the InputImage without drives and cameras.
struct LineSensorsSample {
  std::uint64_t scan = 0;
  InputImage input;  // time_ns and the sensor members; drives and cameras are not carried
};

// sensor_msgs/msg/CompressedImage (ROS 2): std_msgs/Header (builtin_interfaces/Time stamp,
// string frame_id), string format, uint8[] data.
struct CompressedImageSample {
  std::int32_t stamp_sec = 0;
  std::uint32_t stamp_nanosec = 0;
  std::string frame_id;
  std::string format;  // "png"
  Bytes data;
};

Bytes encode(const CameraEstimatesSample& sample);
Bytes encode(const LineCommandSample& sample);
Bytes encode(const LineStatusSample& sample);
Bytes encode(const DriveFeedbackSample& sample);
Bytes encode(const LineSensorsSample& sample);
Bytes encode(const CompressedImageSample& sample);

CameraEstimatesSample decode_camera_estimates(ByteView bytes);
LineCommandSample decode_line_command(ByteView bytes);
LineStatusSample decode_line_status(ByteView bytes);
DriveFeedbackSample decode_drive_feedback(ByteView bytes);
LineSensorsSample decode_line_sensors(ByteView bytes);
CompressedImageSample decode_compressed_image(ByteView bytes);

}  // namespace fl::vision::record
