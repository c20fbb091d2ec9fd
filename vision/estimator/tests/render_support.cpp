#include "render_support.hpp"

#include <cmath>
#include <numbers>

namespace fl::vision::testing {

const render::FilletRenderer& renderer() {
  static const render::FilletRenderer instance(kShapeVariants, 7);
  return instance;
}

render::RenderCamera camera_640() {
  return render::make_top_down_camera(640, 480, render::kLineCameraFieldAlongTravelMm / 640.0);
}

render::RenderCamera camera_line() { return render::make_line_camera(); }

render::RenderCamera camera_line_full_readout() { return render::make_line_camera(false); }

BeltCalibration exact_calibration(const render::RenderCamera& camera) {
  BeltCalibration calibration;
  calibration.camera_name = "test";
  calibration.image_width_px = camera.width_px;
  calibration.image_height_px = camera.height_px;
  calibration.image_to_belt = camera.belt_to_image.inv();
  calibration.image_to_belt *= 1.0 / calibration.image_to_belt(2, 2);
  return calibration;
}

render::ImagingConditions realistic_imaging(cv::RNG& rng) {
  render::ImagingConditions imaging;
  imaging.exposure_gain = rng.uniform(0.75, 1.25);
  imaging.lighting_gradient = rng.uniform(-0.3, 0.3);
  imaging.lighting_gradient_direction_rad = rng.uniform(0.0, 2.0 * std::numbers::pi);
  imaging.vignetting = rng.uniform(0.0, 0.2);
  imaging.motion_blur_px = rng.uniform(0.0, 3.0);
  imaging.noise_sigma = rng.uniform(1.0, 5.0);
  imaging.light_direction = {rng.uniform(-0.4, 0.4), rng.uniform(-0.4, 0.4), 1.0};
  return imaging;
}

double dem_line_bend_per_mm(cv::RNG& rng) {
  // Log-normal magnitude through the DEM line's median (2.0 / m) and 90th percentile (6.7 / m):
  // log-sigma ln(6.7 / 2.0) / 1.2816 = 0.94, capped at the line's largest flat bend, either way.
  constexpr double kMedianPerMm = 2.0e-3;
  constexpr double kLogSigma = 0.94;
  constexpr double kLargestPerMm = 12.0e-3;
  const double magnitude =
      std::min(kLargestPerMm, kMedianPerMm * std::exp(kLogSigma * rng.gaussian(1.0)));
  return rng.uniform(0, 2) == 0 ? magnitude : -magnitude;
}

render::Scene random_scene(const render::RenderCamera& camera, std::uint64_t seed,
                           const RandomSceneOptions& options) {
  cv::RNG rng(seed * 2654435761ULL + 12345ULL);
  render::Scene scene;
  scene.seed = seed;
  if (options.realistic) scene.imaging = realistic_imaging(rng);
  scene.belt.travel_offset_mm = rng.uniform(0.0, 100.0);
  const auto random_fillet = [&] {
    render::FilletInstance fillet;
    fillet.shape_variant = options.nominal_shape ? 0 : rng.uniform(0, kShapeVariants);
    fillet.size_variant = rng.uniform(0, 3);
    fillet.scale = rng.uniform(0.95, 1.05);
    fillet.hand = rng.uniform(0, 2) == 0 ? Hand::kLeft : Hand::kRight;
    fillet.side = rng.uniform(0, 2) == 0 ? SideUp::kSkin : SideUp::kBone;
    fillet.angle_rad = rng.uniform(-std::numbers::pi, std::numbers::pi);
    if (options.bent) fillet.bend_per_mm = dem_line_bend_per_mm(rng);
    return fillet;
  };
  const cv::Point2d corner = render::pixel_to_belt(camera, {0.0, 0.0});
  const double half_x = std::abs(corner.x);
  const double half_y = std::abs(corner.y);
  for (int attempt = 0; attempt < 200; ++attempt) {
    std::vector<render::FilletInstance> middle;
    render::FilletInstance first = random_fillet();
    first.x_mm = rng.uniform(-0.5, 0.5) * half_x;
    first.y_mm = rng.uniform(-0.5, 0.5) * half_y;
    if (options.touching_pair) {
      render::FilletInstance partner = random_fillet();
      // Side by side, either both heads the same way or head to tail, turned up to 20 degrees.
      const double relative =
          rng.uniform(-0.35, 0.35) + (rng.uniform(0, 2) == 0 ? 0.0 : std::numbers::pi);
      partner = render::make_touching_partner(renderer(), first, partner, rng.uniform(0, 2) == 0,
                                              relative, rng.uniform(-40.0, 40.0),
                                              rng.uniform(0.5, 3.0), 1);
      middle = {first, partner};
    } else if (options.overlapping_pair) {
      // One slid 15 to 45 mm (a fifth to three fifths of the 72 mm width) onto the other, at
      // any relative heading: on the bulk belt they land every which way.
      render::FilletInstance partner = random_fillet();
      partner =
          render::make_overlapping_partner(renderer(), first, partner, rng.uniform(0, 2) == 0,
                                           rng.uniform(-std::numbers::pi, std::numbers::pi),
                                           rng.uniform(-50.0, 50.0), rng.uniform(15.0, 45.0), 1);
      middle = {first, partner};
    } else {
      middle = {first};
    }
    bool visible = true;
    for (const auto& fillet : middle) {
      for (const auto& p : renderer().silhouette_outline_mm(fillet)) {
        const cv::Point2d px = render::belt_to_pixel(camera, p);
        if (px.x < 8 || px.y < 8 || px.x > camera.width_px - 9 || px.y > camera.height_px - 9) {
          visible = false;
          break;
        }
      }
    }
    if (!visible) continue;
    scene.fillets = middle;
    break;
  }
  if (options.neighbours) {
    // The fillets before and after, mostly outside the frame along travel, at least 15 mm
    // clear of the fillet(s) in the middle (a closer one would be a touching case).
    const std::size_t middle_count = scene.fillets.size();
    const auto clear_of_middle = [&](const render::FilletInstance& neighbour) {
      const auto outline = renderer().silhouette_outline_mm(neighbour);
      for (std::size_t m = 0; m < middle_count; ++m) {
        const auto middle = renderer().silhouette_outline_mm(scene.fillets[m]);
        for (std::size_t a = 0; a < outline.size(); a += 8) {
          for (std::size_t b = 0; b < middle.size(); b += 8) {
            if (cv::norm(outline[a] - middle[b]) < 15.0) return false;
          }
        }
      }
      return true;
    };
    for (const double sign : {-1.0, 1.0}) {
      for (int attempt = 0; attempt < 20; ++attempt) {
        render::FilletInstance neighbour = random_fillet();
        neighbour.x_mm = sign * (half_x + rng.uniform(20.0, 80.0));
        neighbour.y_mm = rng.uniform(-0.5, 0.5) * half_y;
        if (clear_of_middle(neighbour)) {
          scene.fillets.push_back(neighbour);
          break;
        }
      }
    }
  }
  return scene;
}

double angle_difference_rad(double a, double b) {
  return std::abs(std::remainder(a - b, 2.0 * std::numbers::pi));
}

std::optional<BlobResult> nearest_fillet(const FrameResult& result, cv::Point2d belt_mm,
                                         double gate_mm) {
  std::optional<BlobResult> best;
  double best_distance = gate_mm;
  for (const auto& blob : result.blobs) {
    if (blob.status != BlobStatus::kFillet) continue;
    const double d = std::hypot(blob.estimate.x_mm - belt_mm.x, blob.estimate.y_mm - belt_mm.y);
    if (d < best_distance) {
      best_distance = d;
      best = blob;
    }
  }
  return best;
}

}  // namespace fl::vision::testing
