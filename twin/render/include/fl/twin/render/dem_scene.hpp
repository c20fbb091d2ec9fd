// Pictures of a DEM run for people: an orthographic top view (x along travel, y across) above a
// side view (x, z) of the particles and the walls where they are now, with the simulated time;
// and a video writer for a sequence of them (linectl run --plant dem --video FILE).
#pragma once

#include <filesystem>
#include <memory>
#include <opencv2/core.hpp>

#include "fl/twin/dem/simulation.hpp"

namespace fl::render {

struct DemSceneView {
  double x_min_m = -0.5;  // window along travel
  double x_max_m = 6.5;
  double y_half_width_m = 0.3;  // top view: y in [-w, w]
  double z_min_m = -0.1;        // side view
  double z_max_m = 0.3;
  int width_px = 1920;  // the height follows from the window at equal scale on all axes
};

// BGR image: top view, a 4 px separator, side view. Particles are filled discs coloured per
// body (so each fillet has one colour), mesh walls grey triangle outlines, plane walls a line in
// the side view where they are horizontal. Throws std::invalid_argument for an empty window.
cv::Mat render_dem_scene(const dem::Simulation& simulation, const DemSceneView& view);

// A lossless (.mkv: FFV1) or compressed (.avi: MJPG) video of equally sized frames.
class DemVideoWriter {
 public:
  // Throws std::runtime_error naming the file when OpenCV cannot open it for this extension.
  DemVideoWriter(const std::filesystem::path& file, double frames_per_s, cv::Size frame_size);
  ~DemVideoWriter();
  DemVideoWriter(const DemVideoWriter&) = delete;
  DemVideoWriter& operator=(const DemVideoWriter&) = delete;
  // Throws std::invalid_argument when the frame's size or type differs from the first.
  void write(const cv::Mat& frame_bgr);
  [[nodiscard]] std::size_t frames() const { return frames_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  cv::Size size_;
  std::size_t frames_ = 0;
};

}  // namespace fl::render
