#include "dem_output.hpp"

#include <spdlog/spdlog.h>

#include <cmath>
#include <opencv2/core.hpp>
#include <vector>

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
  if (const BulkScene* bulk = plant_.bulk_end()) {
    if (!vtk_directory.empty()) bulk_vtk_.emplace(vtk_directory / "bulk_end");
    // The whole scene in its own frame: belt, hopper walls and the leveller's rotor.
    const BulkDemConfig& c = bulk->config();
    bulk_view_.x_min_m = c.belt.start_mm * 1e-3 - 0.05;
    bulk_view_.x_max_m = c.belt.discharge_mm * 1e-3 + 0.05;
    bulk_view_.y_half_width_m = c.belt.half_width_mm * 1e-3 + 0.05;
    bulk_view_.z_min_m = -0.05;
    bulk_view_.z_max_m = c.hopper.height_mm * 1e-3 + 0.1;
    bulk_view_.width_px = view_.width_px;
  }
}

void DemRunOutput::on_scan(std::int64_t time_ns) {
  if (time_ns < next_frame_ns_) return;
  next_frame_ns_ += frame_every_ns_ * ((time_ns - next_frame_ns_) / frame_every_ns_ + 1);
  const dem::Simulation& simulation = plant_.simulation();
  const BulkScene* bulk = plant_.bulk_end();
  if (vtk_) vtk_->write(simulation);
  if (bulk_vtk_ && bulk != nullptr) {
    bulk_vtk_->write(bulk->simulation(), plant_.bulk_end_offset_m());
  }
  if (!video_file_.empty()) {
    cv::Mat frame = render::render_dem_scene(simulation, view_);
    if (bulk != nullptr) {
      // The bulk end above the line, a dark band between them.
      const cv::Mat bulk_frame = render::render_dem_scene(bulk->simulation(), bulk_view_);
      const cv::Mat band(8, frame.cols, frame.type(), cv::Scalar::all(40));
      cv::vconcat(std::vector<cv::Mat>{bulk_frame, band, frame}, frame);
    }
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
