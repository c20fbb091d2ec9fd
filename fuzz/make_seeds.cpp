// Writes the generated seed corpora under the directory given (fuzz/corpus): valid inputs
// in each target's layout (fuzz_input.hpp), built with the project's own encoders, so the
// fuzzers start from frames, samples and files the code really exchanges. The YAML seeds are
// the shipped config files, copied by hand (docs/fuzzing.md).
//
//   cmake --build --preset fuzz --target fuzz_make_seeds
//   build/fuzz/fuzz/fuzz_make_seeds fuzz/corpus
#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <string>

#include "can_records.hpp"
#include "fillet_line.h"
#include "fl/controller/config_loader.hpp"
#include "fl/drivers/can_config.hpp"
#include "fl/drivers/canopen.hpp"
#include "fl/mcap/writer.hpp"
#include "fl/vision/record/cdr.hpp"
#include "fl/vision/record/recording.hpp"
#include "fuzz_input.hpp"

namespace {

namespace fs = std::filesystem;
namespace canopen = fl::drivers::canopen;
namespace record = fl::vision::record;
using fl::fuzz::SeedWriter;

void save(const fs::path& directory, const std::string& name,
          const std::vector<std::uint8_t>& bytes) {
  fs::create_directories(directory);
  std::ofstream file(directory / name, std::ios::binary);
  file.write(reinterpret_cast<const char*>(bytes.data()),
             static_cast<std::streamsize>(bytes.size()));
  if (!file) throw std::runtime_error("cannot write " + (directory / name).string());
}

// ---------------------------------------------------------------- fuzz_can_frames

void can_frame(SeedWriter& out, const fl::drivers::CanFrame& frame) {
  out.u8(static_cast<std::uint8_t>(fl::fuzz::CanOp::kFrame));
  fl::fuzz::write_frame(out, frame);
}
void can_cycle(SeedWriter& out) { out.u8(static_cast<std::uint8_t>(fl::fuzz::CanOp::kCycle)); }
void can_output_speed(SeedWriter& out, std::size_t drive, float speed_mps) {
  out.u8(static_cast<std::uint8_t>(fl::fuzz::CanOp::kOutput));
  out.u8(static_cast<std::uint8_t>(drive << 2U));  // selector 0: speed (and enable bit)
  std::uint32_t raw = std::bit_cast<std::uint32_t>(speed_mps) | 1U;
  out.u32(raw);
}

// Every node reports operational and sends its TPDOs; the line runs a few cycles.
void can_frames_seeds(const fs::path& directory, const fl::drivers::CanConfig& config) {
  // No boot-up message here: one after start-up marks the node rebooted, faulted for good.
  SeedWriter running;
  for (const auto& drive : config.drives) {
    can_frame(running, canopen::make_heartbeat(drive.node_id, canopen::NmtState::kOperational));
  }
  for (const auto& module : config.io_modules) {
    can_frame(running, canopen::make_heartbeat(module.node_id, canopen::NmtState::kOperational));
  }
  for (std::size_t d = 0; d < config.drives.size(); ++d) {
    can_output_speed(running, d, 0.25F);
  }
  for (int cycle = 0; cycle < 3; ++cycle) {
    for (const auto& drive : config.drives) {
      const std::array<std::uint32_t, 2> tpdo1{0x0237U, static_cast<std::uint32_t>(cycle * 1000)};
      can_frame(running,
                canopen::pack_pdo(drive.tpdo1_cob_id, canopen::layout::kDriveTpdo1, tpdo1));
      const std::array<std::uint32_t, 1> tpdo2{static_cast<std::uint32_t>(2500)};
      can_frame(running,
                canopen::pack_pdo(drive.tpdo2_cob_id, canopen::layout::kDriveTpdo2, tpdo2));
    }
    for (const auto& module : config.io_modules) {
      const std::array<std::uint32_t, 4> inputs{0x01U, 100U, 200U, 0xFFFFU};
      can_frame(running, canopen::pack_pdo(module.tpdo1_cob_id, canopen::layout::kIoTpdo1, inputs));
    }
    can_cycle(running);
  }
  save(directory, "running_line", running.data());

  // A drive faults with an EMCY and a fault statusword, then clears.
  SeedWriter fault;
  const auto node = config.drives[0].node_id;
  can_frame(fault, canopen::make_heartbeat(node, canopen::NmtState::kOperational));
  can_frame(fault, canopen::make_heartbeat(config.drives[1].node_id, canopen::NmtState::kBootUp));
  can_frame(fault, canopen::make_emcy(node, {0x2310, 0x03, {1, 2, 3, 4, 5}}));
  const std::array<std::uint32_t, 2> faulted{0x0208U, 0U};
  can_frame(fault, canopen::pack_pdo(config.drives[0].tpdo1_cob_id, canopen::layout::kDriveTpdo1,
                                     faulted));
  can_cycle(fault);
  can_frame(fault, canopen::make_emcy(node, {0x0000, 0x00, {}}));
  can_cycle(fault);
  fault.u8(static_cast<std::uint8_t>(fl::fuzz::CanOp::kClockStep));
  fault.u16(5000);  // 500 ms: every heartbeat times out
  fault.u8(3);      // bus off
  can_cycle(fault);
  save(directory, "emcy_fault_heartbeat_lost", fault.data());

  // The emulated devices' services: NMT, SDO requests, SYNC.
  SeedWriter services;
  const auto device = fl::fuzz::kEmulatedDriveNode;
  can_frame(services, canopen::make_nmt(canopen::NmtCommand::kResetNode, canopen::kAllNodes));
  can_cycle(services);
  can_frame(services, canopen::make_sdo_upload(device, {0x1000, 0}));
  can_frame(services, canopen::make_sdo_upload(device, {0x1008, 0}));
  can_frame(services, canopen::make_sdo_upload_segment_request(device, false));
  can_frame(services, canopen::make_sdo_download(device, {0x6040, 0}, 0x000F, 2));
  can_frame(services, canopen::make_sdo_abort(canopen::kSdoRequestBase + device, {0x1008, 0},
                                              canopen::sdo_abort::kGeneral));
  can_frame(services, canopen::make_nmt(canopen::NmtCommand::kStart, device));
  can_frame(services, canopen::make_sync());
  can_cycle(services);
  save(directory, "device_services", services.data());

  // What CANopen refuses: extended and remote frames, error frames, DLC over 8.
  SeedWriter odd;
  fl::drivers::CanFrame frame = canopen::make_heartbeat(node, canopen::NmtState::kOperational);
  frame.extended = true;
  can_frame(odd, frame);
  frame.extended = false;
  frame.remote = true;
  can_frame(odd, frame);
  frame.remote = false;
  frame.dlc = 15;
  can_frame(odd, frame);
  fl::drivers::CanFrame error = fl::drivers::make_frame(0x040, 8);  // CAN_ERR_BUSOFF
  error.error = true;
  can_frame(odd, error);
  can_cycle(odd);
  save(directory, "refused_frames", odd.data());
}

// ---------------------------------------------------------------- fuzz_sdo_client

void sdo_upload(SeedWriter& out, std::uint8_t node, std::uint16_t index, std::uint8_t subindex) {
  out.u8(static_cast<std::uint8_t>(fl::fuzz::SdoOp::kUpload));
  out.u8(static_cast<std::uint8_t>(node - 1));  // the target adds kMinNodeId
  out.u16(index);
  out.u8(subindex);
}
void sdo_download(SeedWriter& out, std::uint8_t node, std::uint16_t index, std::uint8_t subindex,
                  std::uint32_t value, std::uint8_t size_bytes) {
  out.u8(static_cast<std::uint8_t>(fl::fuzz::SdoOp::kDownload));
  out.u8(static_cast<std::uint8_t>(node - 1));
  out.u16(index);
  out.u8(subindex);
  out.u32(value);
  out.u8(static_cast<std::uint8_t>(size_bytes - 1));
}
void sdo_response(SeedWriter& out, const fl::drivers::CanFrame& frame, bool from_node = true) {
  out.u8(static_cast<std::uint8_t>(fl::fuzz::SdoOp::kResponse));
  out.u8(from_node ? 1 : 0);
  fl::fuzz::write_frame(out, frame);
}

void sdo_client_seeds(const fs::path& directory) {
  constexpr std::uint8_t kNode = 3;
  SeedWriter expedited;
  sdo_upload(expedited, kNode, 0x1000, 0);
  expedited.u8(static_cast<std::uint8_t>(fl::fuzz::SdoOp::kQuietPoll));
  sdo_response(expedited,
               canopen::make_sdo_upload_expedited_response(kNode, {0x1000, 0}, 0x00020192, 4));
  sdo_download(expedited, kNode, 0x6040, 0, 0x000F, 2);
  sdo_response(expedited, canopen::make_sdo_download_response(kNode, {0x6040, 0}));
  save(directory, "expedited", expedited.data());

  SeedWriter segmented;
  const std::string name = "fillet drive";
  sdo_upload(segmented, kNode, 0x1008, 0);
  sdo_response(segmented, canopen::make_sdo_upload_segmented_response(
                              kNode, {0x1008, 0}, static_cast<std::uint32_t>(name.size())));
  const auto* text = reinterpret_cast<const std::uint8_t*>(name.data());
  sdo_response(segmented, canopen::make_sdo_upload_segment(kNode, false, {text, 7}, false));
  sdo_response(segmented,
               canopen::make_sdo_upload_segment(kNode, true, {text + 7, name.size() - 7}, true));
  save(directory, "segmented", segmented.data());

  SeedWriter refused;
  sdo_download(refused, kNode, 0x1017, 0, 20, 2);
  sdo_response(refused, canopen::make_heartbeat(kNode, canopen::NmtState::kOperational), false);
  sdo_response(refused, canopen::make_sdo_abort(canopen::kSdoResponseBase + kNode, {0x1017, 0},
                                                canopen::sdo_abort::kNoObject));
  sdo_upload(refused, kNode, 0x6041, 0);  // no answer: times out
  save(directory, "abort_and_timeout", refused.data());
}

// ---------------------------------------------------------------- fuzz_dds_samples

void dds_kind(SeedWriter& out, fl::fuzz::DdsKind kind) { out.u8(static_cast<std::uint8_t>(kind)); }

void dds_camera(SeedWriter& out, std::uint8_t camera, std::int64_t time_ns, std::uint32_t sequence,
                std::uint8_t count, float x_mm, float angle_rad = 0.3F) {
  dds_kind(out, fl::fuzz::DdsKind::kCameraEstimates);
  out.u8(camera);
  out.i64(time_ns);
  out.u32(sequence);
  out.u8(count);
  for (std::size_t i = 0; i < fl::kMaxEstimatesPerFrame; ++i) {
    const bool used = i < count;
    out.f32(used ? x_mm + 60.0F * static_cast<float>(i) : 0.0F);
    out.f32(used ? -10.0F : 0.0F);
    out.f32(used ? angle_rad : 0.0F);
    out.f32(used ? 0.9F : 0.0F);
    out.u32(used ? fl_HAND_LEFT : fl_HAND_UNKNOWN);
    out.u32(used ? fl_SIDE_BONE : fl_SIDE_UNKNOWN);
    out.boolean(used);
  }
}

void dds_sensors(SeedWriter& out, std::int64_t time_ns, bool estop_ok, bool start) {
  dds_kind(out, fl::fuzz::DdsKind::kLineSensors);
  out.i64(time_ns);
  out.u64(static_cast<std::uint64_t>(time_ns / 10'000'000));
  out.boolean(false);  // takt beam
  out.f32(40.0F);      // level
  out.f32(60.0F);      // hopper opening
  out.f32(30.0F);      // leveller speed
  out.boolean(false);  // leveller overload
  out.boolean(false);
  out.boolean(false);
  out.f32(0.0F);  // centring position
  out.boolean(false);
  out.boolean(estop_ok);
  out.boolean(start);
  out.boolean(false);
  out.boolean(false);
}

void dds_feedback(SeedWriter& out, std::uint8_t drive, float speed_mps, std::int64_t counts) {
  dds_kind(out, fl::fuzz::DdsKind::kDriveFeedback);
  out.u8(drive);
  out.i64(0);
  out.f32(speed_mps);
  out.i64(counts);
  out.boolean(true);   // ready
  out.boolean(false);  // fault
}

void dds_samples_seeds(const fs::path& directory) {
  SeedWriter running;
  dds_sensors(running, 0, true, true);
  for (std::uint8_t d = 0; d < fl::kDriveCount; ++d) dds_feedback(running, d, 0.0F, 0);
  for (int scan = 0; scan < 5; ++scan) dds_kind(running, fl::fuzz::DdsKind::kScan);
  for (std::uint8_t d = 0; d < fl::kDriveCount; ++d) dds_feedback(running, d, 0.3F, 9000);
  for (std::uint32_t frame = 1; frame <= 4; ++frame) {
    const std::int64_t time_ns = 1'000'000'000 + frame * 50'000'000LL;
    for (std::uint8_t camera = 0; camera < fl::kCameraCount; ++camera) {
      dds_camera(running, camera, time_ns, frame, static_cast<std::uint8_t>(1 + camera % 3),
                 -100.0F + 20.0F * static_cast<float>(frame));
    }
    for (int scan = 0; scan < 5; ++scan) dds_kind(running, fl::fuzz::DdsKind::kScan);
  }
  save(directory, "running_line", running.data());

  // Samples validate() refuses, then a valid one; a line command both ways.
  SeedWriter refused;
  dds_camera(refused, 7, 0, 1, 1, 0.0F);                                     // camera id
  dds_camera(refused, 0, 0, 2, 9, 0.0F);                                     // count
  dds_camera(refused, 0, 0, 3, 1, std::numeric_limits<float>::quiet_NaN());  // not finite
  dds_camera(refused, 0, 0, 4, 1, 5000.0F);                                  // range
  dds_camera(refused, 0, 0, 5, 1, 0.0F, 4.0F);                               // angle
  dds_camera(refused, 0, -1, 6, 0, 0.0F);                                    // time
  dds_camera(refused, 1, 1'000'000'000, 7, 2, 10.0F);
  dds_kind(refused, fl::fuzz::DdsKind::kScan);
  dds_kind(refused, fl::fuzz::DdsKind::kLineCommand);
  refused.i64(1'000'000'000);
  refused.u64(100);
  for (std::size_t d = 0; d < fl::kDriveCount; ++d) {
    refused.boolean(true);
    refused.f32(0.3F);
    refused.f32(1.0F);
  }
  refused.f32(60.0F);
  refused.f32(30.0F);
  refused.boolean(true);
  refused.boolean(false);
  refused.f32(5.0F);
  refused.boolean(true);
  refused.boolean(false);
  refused.boolean(false);
  dds_feedback(refused, 200, 0.0F, 0);  // drive id out of range
  dds_kind(refused, fl::fuzz::DdsKind::kScan);
  save(directory, "refused_samples", refused.data());
}

// ---------------------------------------------------------------- fuzz_cdr

std::vector<std::uint8_t> typed(fl::fuzz::CdrType type, const record::Bytes& sample) {
  std::vector<std::uint8_t> bytes{static_cast<std::uint8_t>(type)};
  bytes.insert(bytes.end(), sample.begin(), sample.end());
  return bytes;
}

record::CameraEstimatesSample example_estimates(std::uint32_t sequence) {
  record::CameraEstimatesSample sample;
  sample.camera_id = 0;
  sample.frame.frame_time_ns = 1'000'000'000 + sequence * 50'000'000LL;
  sample.frame.sequence = sequence;
  sample.frame.count = 2;
  sample.frame.estimates[0] = {-120.0F,           5.0F, 0.4F, 0.95F, fl::Hand::kLeft,
                               fl::SideUp::kBone, true};
  sample.frame.estimates[1] = {80.0F, -15.0F, -2.9F, 0.7F, fl::Hand::kRight, fl::SideUp::kSkin,
                               false};
  return sample;
}

void cdr_seeds(const fs::path& directory) {
  using fl::fuzz::CdrType;
  save(directory, "camera_estimates",
       typed(CdrType::kCameraEstimates, record::encode(example_estimates(7))));

  record::LineCommandSample command;
  command.time_ns = 1'000'000'000;
  command.scan = 100;
  command.output.drives[1] = {true, 0.3F, 1.5F};
  command.output.hopper_opening_mm = 60.0F;
  command.output.flip_plate1_flip = true;
  save(directory, "line_command", typed(CdrType::kLineCommand, record::encode(command)));

  record::LineStatusSample status;
  status.time_ns = 1'000'000'000;
  status.state = fl::LineState::kRunning;
  status.active_faults = 0x4;
  status.scans = 100;
  status.commands_published = 99;
  status.camera_stale_mask = 0x2;
  save(directory, "line_status", typed(CdrType::kLineStatus, record::encode(status)));

  record::DriveFeedbackSample feedback;
  feedback.drive_id = 3;
  feedback.time_ns = 1'000'000'000;
  feedback.feedback = {0.31F, 123456, true, false};
  save(directory, "drive_feedback", typed(CdrType::kDriveFeedback, record::encode(feedback)));

  record::LineSensorsSample sensors;
  sensors.scan = 100;
  sensors.input.time_ns = 1'000'000'000;
  sensors.input.level_mm = 42.0F;
  sensors.input.estop_ok = true;
  save(directory, "line_sensors", typed(CdrType::kLineSensors, record::encode(sensors)));

  record::CompressedImageSample image;
  image.stamp_sec = 1;
  image.stamp_nanosec = 500;
  image.frame_id = "orientation";
  image.format = "png";
  image.data = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  save(directory, "compressed_image", typed(CdrType::kCompressedImage, record::encode(image)));
}

// ---------------------------------------------------------------- fuzz_mcap_reader

// A small recording as linectl record writes it: the IDL schema, estimates and image channels,
// a calibration attachment and metadata, in several chunks.
std::vector<std::uint8_t> small_recording(fl::mcap::WriterOptions options, std::uint8_t flags) {
  std::ostringstream stream;
  {
    options.profile = "ros2";
    options.chunk_size = 512;
    fl::mcap::Writer writer(stream, options);
    const std::string_view idl = "module fl { struct Tiny { octet id; }; };";
    const std::uint16_t schema =
        writer.add_schema("fl::CameraEstimates", "omgidl",
                          {reinterpret_cast<const std::uint8_t*>(idl.data()), idl.size()});
    const std::uint16_t estimates =
        writer.add_channel(schema, record::estimates_topic(fl::CameraId::kOrientation), "cdr",
                           {{"camera", "orientation"}});
    const std::uint16_t images =
        writer.add_channel(0, record::image_topic(fl::CameraId::kOrientation), "cdr");
    for (std::uint32_t sequence = 1; sequence <= 4; ++sequence) {
      const record::Bytes estimate = record::encode(example_estimates(sequence));
      const fl::mcap::Timestamp time = 1'000'000'000ULL + sequence * 50'000'000ULL;
      writer.write_message({estimates, sequence, time, time, estimate});
      record::CompressedImageSample image;
      image.format = "png";
      image.data.assign(24, static_cast<std::uint8_t>(sequence));
      const record::Bytes image_bytes = record::encode(image);
      writer.write_message({images, sequence, time + 1, time + 1, image_bytes});
    }
    fl::mcap::Attachment attachment;
    attachment.name = record::calibration_attachment(fl::CameraId::kOrientation);
    attachment.media_type = "application/yaml";
    const std::string_view yaml = "pixels_per_mm: 2.5\n";
    attachment.data.assign(yaml.begin(), yaml.end());
    writer.write_attachment(attachment);
    writer.write_metadata({"run", {{"seed", "1"}, {"plant", "fast"}}});
    writer.close();
  }
  const std::string file = stream.str();
  std::vector<std::uint8_t> bytes{flags};
  bytes.insert(bytes.end(), file.begin(), file.end());
  return bytes;
}

void mcap_seeds(const fs::path& directory) {
  fl::mcap::WriterOptions zstd;
  zstd.compression = fl::mcap::Compression::kZstd;
  save(directory, "zstd_chunks", small_recording(zstd, fl::fuzz::kMcapValidateCrcs));
  save(directory, "zstd_chunks_no_crc_check", small_recording(zstd, 0));
  fl::mcap::WriterOptions lz4;
  lz4.compression = fl::mcap::Compression::kLz4;
  save(directory, "lz4_chunks", small_recording(lz4, fl::fuzz::kMcapValidateCrcs));
  fl::mcap::WriterOptions plain;
  plain.compression = fl::mcap::Compression::kNone;
  save(directory, "uncompressed_chunks", small_recording(plain, fl::fuzz::kMcapValidateCrcs));
  fl::mcap::WriterOptions unindexed;
  unindexed.use_chunks = false;
  unindexed.write_summary = false;
  save(directory, "unindexed_no_summary", small_recording(unindexed, fl::fuzz::kMcapValidateCrcs));
}

}  // namespace

// ---------------------------------------------------------------- fuzz_png_frames

// Small frames as the recorder writes them (cv::imencode): grey and colour, a smooth
// gradient and noise (which make libpng choose different row filters), fast and best zlib.
void png_seeds(const fs::path& directory) {
  cv::RNG random(7);
  for (const int channels : {1, 3}) {
    for (const bool noisy : {false, true}) {
      cv::Mat image(12, 16, CV_8UC(channels));
      for (int y = 0; y < image.rows; ++y) {
        for (int i = 0; i < image.cols * channels; ++i) {
          image.ptr<std::uint8_t>(y)[i] =
              static_cast<std::uint8_t>(noisy ? random.uniform(0, 256) : 10 * y + i);
        }
      }
      for (const int level : {1, 9}) {
        std::vector<std::uint8_t> png;
        cv::imencode(".png", image, png, {cv::IMWRITE_PNG_COMPRESSION, level});
        save(directory,
             "frame_c" + std::to_string(channels) + (noisy ? "_noise" : "_gradient") + "_z" +
                 std::to_string(level) + ".png",
             png);
      }
    }
  }
}

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: fuzz_make_seeds CORPUS_DIR (fuzz/corpus)\n";
    return 2;
  }
  const fs::path corpus = argv[1];
  try {
    const fl::LineConfig line = fl::load_line_config(FL_SOURCE_DIR "/config/line.yaml");
    const fl::drivers::CanConfig can =
        fl::drivers::load_can_config(FL_SOURCE_DIR "/config/can.yaml", line);
    can_frames_seeds(corpus / "fuzz_can_frames", can);
    sdo_client_seeds(corpus / "fuzz_sdo_client");
    dds_samples_seeds(corpus / "fuzz_dds_samples");
    cdr_seeds(corpus / "fuzz_cdr");
    mcap_seeds(corpus / "fuzz_mcap_reader");
    png_seeds(corpus / "fuzz_png_frames");
  } catch (const std::exception& error) {
    std::cerr << "fuzz_make_seeds: " << error.what() << "\n";
    return 1;
  }
  return 0;
}
