#include "control_recording.hpp"

#include <array>
#include <memory>
#include <optional>

#include "fl/controller/ledger.hpp"
#include "fl/vision/record/recording.hpp"

namespace fl::apps {
namespace {

namespace rec = fl::vision::record;

struct ScanImages {
  std::uint64_t scan = 0;
  InputImage in{};
  OutputImage out{};
};

class McapControlRecorder final : public ControlRecorder {
 public:
  McapControlRecorder(const std::string& line_yaml_text, const std::string& path)
      : writer_(path, settings()) {
    // No frames: the camera nodes measured them elsewhere; their estimates are the input.
    for (std::size_t c = 0; c < kCameraCount; ++c) {
      writer_.add_camera(static_cast<CameraId>(c), std::nullopt);
    }
    writer_.attach_line_config(line_yaml_text);
  }

  void on_scan(std::uint64_t scan, const InputImage& in, const OutputImage& out) override {
    ring_->push(ScanImages{scan, in, out});  // full: counted by the ring, never blocking
  }

  void drain() override {
    while (const std::optional<ScanImages> images = ring_->pop()) write(*images);
  }

  void close() override {
    drain();
    writer_.close();
  }

  [[nodiscard]] std::uint64_t scans_written() const override { return written_; }
  [[nodiscard]] std::uint64_t scans_dropped() const override { return ring_->dropped(); }

 private:
  static rec::WriterSettings settings() {
    rec::WriterSettings settings;
    settings.info = {{"source", "linectl control"}, {"plant", "the line behind the controller"}};
    return settings;
  }

  void write(const ScanImages& images) {
    // A camera's estimates are written in the scan that received a new frame of it, as
    // the twin's recorder does, so that the replay delivers them in the same scan.
    for (std::size_t c = 0; c < kCameraCount; ++c) {
      const CameraFrame& frame = images.in.cameras[c];
      if (frame.sequence != last_[c].sequence || frame.frame_time_ns != last_[c].frame_time_ns) {
        writer_.write_estimates(static_cast<CameraId>(c), images.in.time_ns, frame);
        last_[c] = frame;
      }
    }
    writer_.write_scan(images.scan, images.in, images.out);
    ++written_;
  }

  rec::RecordingWriter writer_;
  // 512 scans, 5 s at 10 ms: the drain empties it every 20 ms. Allocated once, here.
  std::unique_ptr<FixedRing<ScanImages, 512>> ring_ =
      std::make_unique<FixedRing<ScanImages, 512>>();
  std::array<CameraFrame, kCameraCount> last_{};
  std::uint64_t written_ = 0;
};

}  // namespace

ControlRecorderFactory control_recorder_factory() {
  return [](const std::string& line_yaml_text,
            const std::string& path) -> std::unique_ptr<ControlRecorder> {
    return std::make_unique<McapControlRecorder>(line_yaml_text, path);
  };
}

}  // namespace fl::apps
