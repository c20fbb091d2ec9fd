// Pictures of a DEM closed-loop run for people: `linectl run --plant dem --vtk DIR` writes a
// ParaView series (particles and walls, DIR/run.pvd) and `--video FILE` (.mkv lossless or .avi)
// a top and side view of the line, one frame every `--frame-every` of line time. With the bulk
// end as DEM (--infeed dem_bulk_end) its scene is written too: DIR/bulk_end/run.pvd, placed
// where it stands in the line's frame, and a top and side view of it above the line's.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>

#include "fl/twin/dem/vtk_writer.hpp"
#include "fl/twin/dem_plant/dem_plant.hpp"
#include "fl/twin/render/dem_scene.hpp"

namespace fl::apps {

class DemRunOutput {
 public:
  // Throws std::runtime_error naming the directory or file it cannot write.
  DemRunOutput(const DemPlant& plant, const std::filesystem::path& vtk_directory,
               const std::filesystem::path& video_file, double frame_every_s, double line_length_m);
  // Writes a frame when the line time has reached the next frame time.
  void on_scan(std::int64_t time_ns);
  [[nodiscard]] std::size_t frames() const { return frames_; }

 private:
  const DemPlant& plant_;
  std::optional<dem::VtkSeriesWriter> vtk_;
  std::optional<dem::VtkSeriesWriter> bulk_vtk_;
  std::unique_ptr<render::DemVideoWriter> video_;
  std::filesystem::path video_file_;
  render::DemSceneView view_;
  render::DemSceneView bulk_view_;
  std::int64_t frame_every_ns_;
  std::int64_t next_frame_ns_ = 0;
  std::size_t frames_ = 0;
};

}  // namespace fl::apps
