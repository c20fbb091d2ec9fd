#include "fl/twin/render/dem_scene.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <stdexcept>

namespace fl::render {
namespace {

const cv::Scalar kBackground(245, 245, 245);
const cv::Scalar kWall(150, 150, 150);
const cv::Scalar kText(40, 40, 40);

// Distinct, stable colours per body: hue steps by the golden ratio.
cv::Scalar body_colour(std::uint32_t body) {
  const double hue = std::fmod(static_cast<double>(body) * 0.618033988749895, 1.0);
  cv::Mat hsv(1, 1, CV_8UC3, cv::Scalar(hue * 180.0, 170, 215));
  cv::Mat bgr;
  cv::cvtColor(hsv, bgr, cv::COLOR_HSV2BGR);
  const cv::Vec3b c = bgr.at<cv::Vec3b>(0, 0);
  return {static_cast<double>(c[0]), static_cast<double>(c[1]), static_cast<double>(c[2])};
}

struct Projection {  // one view: metres on two axes -> pixels (v grows downwards)
  double u0_m;
  double v_top_m;
  double px_per_m;
  [[nodiscard]] cv::Point at(double u_m, double v_m) const {
    return {static_cast<int>(std::lround((u_m - u0_m) * px_per_m)),
            static_cast<int>(std::lround((v_top_m - v_m) * px_per_m))};
  }
};

}  // namespace

cv::Mat render_dem_scene(const dem::Simulation& simulation, const DemSceneView& view) {
  const double length_m = view.x_max_m - view.x_min_m;
  if (!(length_m > 0.0) || !(view.y_half_width_m > 0.0) || !(view.z_max_m > view.z_min_m) ||
      view.width_px < 16) {
    throw std::invalid_argument("render_dem_scene: empty window or width under 16 px");
  }
  const double px_per_m = view.width_px / length_m;
  const int top_height = static_cast<int>(std::lround(2.0 * view.y_half_width_m * px_per_m));
  const int side_height = static_cast<int>(std::lround((view.z_max_m - view.z_min_m) * px_per_m));
  constexpr int kSeparator = 4;
  // even sizes: video codecs with chroma subsampling reject odd ones
  const int rows = (top_height + kSeparator + side_height + 1) / 2 * 2;
  const int cols = (view.width_px + 1) / 2 * 2;
  cv::Mat image(rows, cols, CV_8UC3, kBackground);
  image.rowRange(top_height, top_height + kSeparator).setTo(cv::Scalar(90, 90, 90));

  const dem::ModelSpec& spec = simulation.model().spec();
  const dem::State& state = simulation.state();
  cv::Mat top_view = image.rowRange(0, top_height);
  cv::Mat side_view = image.rowRange(top_height + kSeparator, image.rows);
  const Projection top_local{view.x_min_m, view.y_half_width_m, px_per_m};
  const Projection side_local{view.x_min_m, view.z_max_m, px_per_m};
  for (std::size_t m = 0; m < spec.meshes.size(); ++m) {
    const dem::WallState& wall = state.walls[spec.planes.size() + m];
    for (const dem::Triangle& triangle : spec.meshes[m].triangles) {
      std::array<cv::Point, 3> in_top;
      std::array<cv::Point, 3> in_side;
      for (int v = 0; v < 3; ++v) {
        const dem::Vec3 p = wall.place(triangle.vertices_m[static_cast<std::size_t>(v)]);
        in_top[static_cast<std::size_t>(v)] = top_local.at(p.x(), p.y());
        in_side[static_cast<std::size_t>(v)] = side_local.at(p.x(), p.z());
      }
      cv::polylines(top_view, std::vector<cv::Point>(in_top.begin(), in_top.end()), true, kWall);
      cv::polylines(side_view, std::vector<cv::Point>(in_side.begin(), in_side.end()), true, kWall);
    }
  }
  for (std::size_t p = 0; p < spec.planes.size(); ++p) {
    const dem::WallState& wall = state.walls[p];
    const dem::Vec3 normal = (wall.rotation * spec.planes[p].normal).normalized();
    if (std::abs(normal.z()) < 0.99) continue;  // only floors and ceilings have a clear trace
    const double z = wall.place(spec.planes[p].point_m).z();
    cv::line(side_view, side_local.at(view.x_min_m, z), side_local.at(view.x_max_m, z), kWall, 2);
  }
  // particles, lowest first in the top view so that the visible top layer is drawn last
  std::vector<std::uint32_t> order(state.size());
  for (std::uint32_t k = 0; k < order.size(); ++k) order[k] = k;
  std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
    return state.position_m[a].z() < state.position_m[b].z();
  });
  for (const std::uint32_t k : order) {
    const dem::Vec3& x = state.position_m[k];
    const int radius_px = std::max(1, static_cast<int>(std::lround(state.radius_m[k] * px_per_m)));
    const cv::Scalar colour = body_colour(state.body[k]);
    cv::circle(top_view, top_local.at(x.x(), x.y()), radius_px, colour, cv::FILLED, cv::LINE_AA);
    cv::circle(side_view, side_local.at(x.x(), x.z()), radius_px, colour, cv::FILLED, cv::LINE_AA);
  }
  char label[96];
  std::snprintf(label, sizeof label, "t = %.3f s   %zu particles   top view / side view",
                state.time_s, state.size());
  cv::putText(image, label, {10, 24}, cv::FONT_HERSHEY_SIMPLEX, 0.6, kText, 1, cv::LINE_AA);
  return image;
}

struct DemVideoWriter::Impl {
  cv::VideoWriter writer;
};

DemVideoWriter::DemVideoWriter(const std::filesystem::path& file, double frames_per_s,
                               cv::Size frame_size)
    : impl_(std::make_unique<Impl>()), size_(frame_size) {
  const std::string extension = file.extension().string();
  int fourcc = 0;
  if (extension == ".mkv") {
    fourcc = cv::VideoWriter::fourcc('F', 'F', 'V', '1');  // lossless
  } else if (extension == ".avi") {
    fourcc = cv::VideoWriter::fourcc('M', 'J', 'P', 'G');
  } else {
    throw std::runtime_error("video " + file.string() + ": use .mkv (FFV1) or .avi (MJPG)");
  }
  if (!(frames_per_s > 0.0) || frame_size.width <= 0 || frame_size.height <= 0 ||
      !impl_->writer.open(file.string(), cv::CAP_FFMPEG, fourcc, frames_per_s, frame_size, true)) {
    throw std::runtime_error(
        "video " + file.string() + ": OpenCV cannot open it for writing (FFmpeg backend, size " +
        std::to_string(frame_size.width) + "x" + std::to_string(frame_size.height) + ")");
  }
}

DemVideoWriter::~DemVideoWriter() = default;

void DemVideoWriter::write(const cv::Mat& frame_bgr) {
  if (frame_bgr.size() != size_ || frame_bgr.type() != CV_8UC3) {
    throw std::invalid_argument("video: frame of another size or type than the video's");
  }
  impl_->writer.write(frame_bgr);
  ++frames_;
}

}  // namespace fl::render
