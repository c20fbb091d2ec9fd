#include "dem_output.hpp"

#include <spdlog/spdlog.h>

#include <cmath>

namespace fl::apps {

DemRunOutput::DemRunOutput(const DemPlant& plant, const std::filesystem::path& vtk_directory,
                           const std::filesystem::path& video_file, double frame_every_s,
                           double line_length_m)
    : plant_(plant),
      video_file_(video_file),
      frame_every_ns_(static_cast<std::int64_t>(std::llround(frame_every_s * 1e9))) {
  if (frame_every_ns_ <= 0) throw std::runtime_error("--frame-every: must be positive");
  if (!vtk_directory.empty()) vtk_.emplace(vtk_directory);
  view_.x_min_m = -0.3;  // the feed end of the takt belt
  view_.x_max_m = line_length_m + 0.2;
}

void DemRunOutput::on_scan(std::int64_t time_ns) {
  if (time_ns < next_frame_ns_) return;
  next_frame_ns_ += frame_every_ns_ * ((time_ns - next_frame_ns_) / frame_every_ns_ + 1);
  const dem::Simulation& simulation = plant_.simulation();
  if (vtk_) vtk_->write(simulation);
  if (!video_file_.empty()) {
    const cv::Mat frame = render::render_dem_scene(simulation, view_);
    if (!video_) {
      // one video second per second of line time at the chosen frame spacing
      video_ = std::make_unique<render::DemVideoWriter>(
          video_file_, 1e9 / static_cast<double>(frame_every_ns_), frame.size());
    }
    video_->write(frame);
  }
  ++frames_;
  if (frames_ == 1) {
    spdlog::info("writing frames every {:.3f} s of line time{}{}",
                 static_cast<double>(frame_every_ns_) / 1e9,
                 vtk_ ? " to " + vtk_->collection_file().string() : std::string(),
                 video_file_.empty() ? std::string() : " and " + video_file_.string());
  }
}

}  // namespace fl::apps
