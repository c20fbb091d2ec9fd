// Camera models and the imaging chain (exposure, lighting, blur, noise) of the renderer.
#include "imaging.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "fl/twin/render/fillet_renderer.hpp"

namespace fl::render {

RenderCamera make_top_down_camera(int width_px, int height_px, double mm_per_px, double yaw_rad) {
  if (width_px <= 0 || height_px <= 0 || !(mm_per_px > 0.0)) {
    throw std::invalid_argument("make_top_down_camera: size and mm_per_px must be positive");
  }
  const double c = std::cos(yaw_rad);
  const double s = std::sin(yaw_rad);
  const double cx = 0.5 * (width_px - 1);
  const double cy = 0.5 * (height_px - 1);
  // Belt x -> +u and belt y -> -v at yaw 0; the yaw turns the belt frame in the image.
  const double k = 1.0 / mm_per_px;
  RenderCamera camera;
  camera.width_px = width_px;
  camera.height_px = height_px;
  camera.belt_to_image = cv::Matx33d(k * c, -k * s, cx, -k * s, -k * c, cy, 0.0, 0.0, 1.0);
  return camera;
}

RenderCamera make_line_camera(bool binned) {
  const int binning = binned ? kLineCameraBinning : 1;
  const int width_px = kLineSensorWidthPx / binning;
  RenderCamera camera = make_top_down_camera(width_px, kLineSensorHeightPx / binning,
                                             kLineCameraFieldAlongTravelMm / width_px);
  camera.binning = binning;
  return camera;
}

RenderCamera sensor_of(const RenderCamera& camera) {
  if (camera.binning < 1) throw std::invalid_argument("RenderCamera: binning < 1");
  if (camera.binning == 1) return camera;
  const double b = camera.binning;
  // Delivered pixel centre p -> sensor pixel b p + (b - 1) / 2, the centre of its block.
  const double offset = 0.5 * (b - 1.0);
  const cv::Matx33d delivered_to_sensor(b, 0.0, offset, 0.0, b, offset, 0.0, 0.0, 1.0);
  RenderCamera sensor;
  sensor.width_px = camera.width_px * camera.binning;
  sensor.height_px = camera.height_px * camera.binning;
  sensor.belt_to_image = delivered_to_sensor * camera.belt_to_image;
  return sensor;
}

RenderCamera make_pinhole_camera(int width_px, int height_px, const cv::Matx33d& camera_matrix,
                                 const cv::Matx33d& rotation_camera_from_belt,
                                 const cv::Vec3d& translation_camera_from_belt_mm) {
  const cv::Matx33d& r = rotation_camera_from_belt;
  const cv::Vec3d& t = translation_camera_from_belt_mm;
  const cv::Matx33d extrinsic(r(0, 0), r(0, 1), t[0], r(1, 0), r(1, 1), t[1], r(2, 0), r(2, 1),
                              t[2]);
  RenderCamera camera;
  camera.width_px = width_px;
  camera.height_px = height_px;
  camera.belt_to_image = camera_matrix * extrinsic;
  camera.belt_to_image *= 1.0 / camera.belt_to_image(2, 2);
  return camera;
}

namespace {

cv::Matx33d tilted_rotation(double tilt_x_rad, double tilt_y_rad, double yaw_rad) {
  // Straight down: camera x = belt x, camera y = -belt y, camera z (optical axis) = -belt z.
  const cv::Matx33d down(1, 0, 0, 0, -1, 0, 0, 0, -1);
  const double cz = std::cos(yaw_rad);
  const double sz = std::sin(yaw_rad);
  const cv::Matx33d yaw(cz, sz, 0, -sz, cz, 0, 0, 0, 1);
  const double cx = std::cos(tilt_x_rad);
  const double sx = std::sin(tilt_x_rad);
  const cv::Matx33d tilt_x(1, 0, 0, 0, cx, -sx, 0, sx, cx);
  const double cy = std::cos(tilt_y_rad);
  const double sy = std::sin(tilt_y_rad);
  const cv::Matx33d tilt_y(cy, 0, sy, 0, 1, 0, -sy, 0, cy);
  return tilt_y * tilt_x * yaw * down;
}

}  // namespace

RenderCamera make_orbit_camera(int width_px, int height_px, const cv::Matx33d& camera_matrix,
                               double distance_mm, double tilt_x_rad, double tilt_y_rad,
                               double yaw_rad) {
  // The belt origin sits on the optical axis at `distance_mm`.
  return make_pinhole_camera(width_px, height_px, camera_matrix,
                             tilted_rotation(tilt_x_rad, tilt_y_rad, yaw_rad),
                             cv::Vec3d(0.0, 0.0, distance_mm));
}

RenderCamera make_tilted_camera(int width_px, int height_px, const cv::Matx33d& camera_matrix,
                                double height_mm, double tilt_x_rad, double tilt_y_rad,
                                double yaw_rad) {
  const cv::Matx33d rotation = tilted_rotation(tilt_x_rad, tilt_y_rad, yaw_rad);
  // The camera centre sits `height_mm` above the belt origin; t = -R * centre.
  const cv::Vec3d centre(0.0, 0.0, height_mm);
  const cv::Vec3d translation = -(rotation * centre);
  return make_pinhole_camera(width_px, height_px, camera_matrix, rotation, translation);
}

cv::Point2d belt_to_pixel(const RenderCamera& camera, cv::Point2d belt_mm) {
  const cv::Vec3d p = camera.belt_to_image * cv::Vec3d(belt_mm.x, belt_mm.y, 1.0);
  return {p[0] / p[2], p[1] / p[2]};
}

cv::Point2d pixel_to_belt(const RenderCamera& camera, cv::Point2d pixel) {
  const cv::Vec3d p = camera.belt_to_image.inv() * cv::Vec3d(pixel.x, pixel.y, 1.0);
  return {p[0] / p[2], p[1] / p[2]};
}

namespace detail {

cv::Mat apply_imaging(const cv::Mat& radiance_bgr, const RenderCamera& camera,
                      const ImagingConditions& imaging, std::uint64_t seed) {
  CV_Assert(radiance_bgr.type() == CV_32FC3);
  const RenderCamera sensor = sensor_of(camera);
  CV_Assert(radiance_bgr.cols == sensor.width_px && radiance_bgr.rows == sensor.height_px);
  const int width = radiance_bgr.cols;
  const int height = radiance_bgr.rows;
  cv::Mat image = radiance_bgr.clone();

  // Illumination: exposure x linear gradient x vignetting, one factor per pixel.
  const double gx = std::cos(imaging.lighting_gradient_direction_rad);
  const double gy = std::sin(imaging.lighting_gradient_direction_rad);
  const double half_w = 0.5 * (width - 1);
  const double half_h = 0.5 * (height - 1);
  // Largest projection of a pixel offset on the gradient direction: the gradient's full swing
  // spans the image edge to edge.
  const double extent = std::abs(gx) * half_w + std::abs(gy) * half_h;
  const double corner_radius2 = half_w * half_w + half_h * half_h;
  for (int row = 0; row < height; ++row) {
    auto* pixel = image.ptr<cv::Vec3f>(row);
    for (int col = 0; col < width; ++col) {
      const double du = col - half_w;
      const double dv = row - half_h;
      const double along = extent > 0.0 ? (du * gx + dv * gy) / extent : 0.0;  // -1..1
      const double radial2 = (du * du + dv * dv) / corner_radius2;             // 0..1
      const double factor = imaging.exposure_gain *
                            (1.0 + 0.5 * imaging.lighting_gradient * along) *
                            (1.0 - imaging.vignetting * radial2 * radial2);
      pixel[col] *= static_cast<float>(factor);
    }
  }

  // Motion blur: a line kernel along the image direction of belt travel.
  // The blur length is given in delivered pixels; on the sensor it spans binning times as many.
  const double blur_px = imaging.motion_blur_px * camera.binning;
  if (blur_px > 0.5) {
    const cv::Point2d origin = belt_to_pixel(sensor, {0.0, 0.0});
    const cv::Point2d ahead = belt_to_pixel(sensor, {10.0, 0.0});
    const double angle = std::atan2(ahead.y - origin.y, ahead.x - origin.x);
    const int size = static_cast<int>(std::ceil(blur_px)) | 1;
    cv::Mat kernel = cv::Mat::zeros(size, size, CV_32F);
    const double half = 0.5 * blur_px;
    constexpr int kSamples = 64;
    const double centre = 0.5 * (size - 1);
    for (int i = 0; i < kSamples; ++i) {
      const double t = -half + blur_px * (i + 0.5) / kSamples;
      const int kx = static_cast<int>(std::lround(centre + t * std::cos(angle)));
      const int ky = static_cast<int>(std::lround(centre + t * std::sin(angle)));
      if (kx >= 0 && kx < size && ky >= 0 && ky < size) kernel.at<float>(ky, kx) += 1.0F;
    }
    kernel /= cv::sum(kernel)[0];
    cv::filter2D(image, image, -1, kernel, cv::Point(-1, -1), 0.0, cv::BORDER_REFLECT);
  }

  if (imaging.noise_sigma > 0.0) {
    cv::Mat noise(image.size(), CV_32FC3);
    cv::RNG rng(seed ^ 0x5DEECE66DULL);
    rng.fill(noise, cv::RNG::NORMAL, cv::Scalar::all(0.0), cv::Scalar::all(imaging.noise_sigma));
    image += noise;
  }
  cv::Mat out;
  image.convertTo(out, CV_8UC3);  // rounds and saturates to 0..255
  if (camera.binning == 1) return out;
  cv::Mat binned;
  cv::resize(out, binned, cv::Size(camera.width_px, camera.height_px), 0.0, 0.0, cv::INTER_AREA);
  return binned;
}

}  // namespace detail
}  // namespace fl::render
