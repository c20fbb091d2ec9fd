// Synthetic top-down camera frames of fillets lying on a belt (issue 3 item 4), for testing
// and evaluating the vision estimator without a real line.
//
// Geometry: every fillet is the project's procedural mesh (fl/twin/dem/fillet_generator.hpp)
// in one of the table 3.1 sizes, left or mirrored right, and skin side up (the mesh's domed +z
// top) or bone side up (turned over about its long axis: y -> -y, z -> -z). Its top surface
// is rasterised once into a height map in the fillet's own frame (u from the thick end to the
// tip, v to the left of that, millimetres); a frame samples that height map through the
// camera's belt-plane homography, so silhouette, thickness and surface normals all come from
// the mesh.
//
// Appearance (a plausible model, not a measured one; see docs/benchmarks.md (vision)):
// - belt: a uniform colour (food-grade blue by default) with fine grain and the darker hinge
//   lines of a modular belt every `hinge_pitch_mm` across travel;
// - meat: a base colour per side, jittered per fillet. Skin side: paler and less saturated,
//   smooth (low-frequency mottling only) with a glossy specular highlight. Bone side: pinker,
//   with muscle-fibre streaks along the fillet (anisotropic noise) and a few whitish fat /
//   connective-tissue streaks, and only a weak, broad highlight;
// - thickness: Lambert shading from the height map's normals, thicker meat slightly brighter
//   (closer to the light, less belt colour through the meat) and the thin rim translucent
//   (mixed with the belt colour under it), so the thick end is visible;
// - imaging: exposure gain, a linear lighting gradient, vignetting, motion blur along travel,
//   Gaussian sensor noise, 8-bit clipping; all settable and seeded.
// Not modelled: shadows, lens distortion, blood spots, wet reflections of the belt, occlusion
// by machine parts. Overlapping fillets are resolved by height (the higher surface is seen).
//
// Belt frame (as FilletEstimate): x along travel, y to the left looking downstream, millimetres.
// A fillet's pose is the belt position of its mesh origin (the volume centroid) and the angle
// of its thick-end-to-tip axis, counter-clockwise from travel.
#pragma once

#include <cstdint>
#include <limits>
#include <memory>
#include <opencv2/core.hpp>
#include <vector>

#include "fl/controller/process_image.hpp"

namespace fl::render {

// The line cameras (camera 1, 2 and final: 300 mm field along travel): a 1280 x 1024 sensor, a
// common 1.3 MP machine-vision sensor (0.234 mm/px over 300 mm), set to bin 2 x 2 in the camera.
// They deliver 640 x 512 px at 0.47 mm/px: the scale the estimator measures at
// (EstimatorParams::working_mm_per_px), so the link carries a quarter of the pixels and the line
// PC does not average them down itself (docs/vision.md, "The line cameras").
inline constexpr int kLineSensorWidthPx = 1280;
inline constexpr int kLineSensorHeightPx = 1024;
inline constexpr int kLineCameraBinning = 2;
inline constexpr int kLineCameraWidthPx = kLineSensorWidthPx / kLineCameraBinning;
inline constexpr int kLineCameraHeightPx = kLineSensorHeightPx / kLineCameraBinning;
inline constexpr double kLineCameraFieldAlongTravelMm = 300.0;

struct RenderCamera {
  int width_px = 640;  // the delivered image
  int height_px = 480;
  // Belt millimetres (x, y, 1) -> homogeneous pixel (u right, v down, pixel centres at
  // integers) of the delivered image.
  cv::Matx33d belt_to_image = cv::Matx33d::eye();
  // Sensor pixels averaged into one delivered pixel along each axis (1: none). The sensor has
  // binning times the delivered size; light, blur and noise are imaged on the sensor's pixels,
  // and each binning x binning block's 8-bit values are averaged, rounded half up (a camera's
  // digital binning, and cv::resize INTER_AREA at an integer factor).
  int binning = 1;
};

// Looking straight down: belt x (travel) along +u, belt y (left) along -v, the belt origin at
// the image centre; `yaw_rad` turns the image axes counter-clockwise against the belt's.
RenderCamera make_top_down_camera(int width_px, int height_px, double mm_per_px,
                                  double yaw_rad = 0.0);
// The line camera as mounted on the line: top down over kLineCameraFieldAlongTravelMm, binned
// (kLineCameraWidthPx x kLineCameraHeightPx), or its sensor read out in full (`binned` false:
// kLineSensorWidthPx x kLineSensorHeightPx).
RenderCamera make_line_camera(bool binned = true);
// The sensor behind a binned camera: binning times the size, each delivered pixel's block
// centred on it. A camera without binning is its own sensor.
RenderCamera sensor_of(const RenderCamera& camera);
// Pinhole camera K [r1 r2 t] looking at the belt plane z = 0: `rotation_camera_from_belt` and
// `translation_camera_from_belt_mm` map belt points (x, y, 0) into camera coordinates.
RenderCamera make_pinhole_camera(int width_px, int height_px, const cv::Matx33d& camera_matrix,
                                 const cv::Matx33d& rotation_camera_from_belt,
                                 const cv::Vec3d& translation_camera_from_belt_mm);
// Camera `height_mm` above the belt origin looking down, tilted by `tilt_x_rad` about the
// image's u axis and `tilt_y_rad` about its v axis (for perspective and calibration views).
RenderCamera make_tilted_camera(int width_px, int height_px, const cv::Matx33d& camera_matrix,
                                double height_mm, double tilt_x_rad, double tilt_y_rad,
                                double yaw_rad = 0.0);
// The same rotations, but the camera orbits the belt origin, which stays on the optical axis at
// `distance_mm` (calibration views of a board centred on the origin).
RenderCamera make_orbit_camera(int width_px, int height_px, const cv::Matx33d& camera_matrix,
                               double distance_mm, double tilt_x_rad, double tilt_y_rad,
                               double yaw_rad = 0.0);
// Belt point -> pixel and back through the camera's homography.
cv::Point2d belt_to_pixel(const RenderCamera& camera, cv::Point2d belt_mm);
cv::Point2d pixel_to_belt(const RenderCamera& camera, cv::Point2d pixel);

struct BeltAppearance {
  cv::Vec3d colour_bgr{165.0, 105.0, 35.0};  // food-grade blue
  double grain_amplitude = 6.0;              // grey levels, fine per-sample grain
  double hinge_pitch_mm = 25.4;              // modular belt pitch (1 inch)
  double hinge_width_mm = 1.5;
  double hinge_darkening = 0.25;  // relative
  double travel_offset_mm = 0.0;  // belt position: moves the hinge lines
};

struct ImagingConditions {
  double exposure_gain = 1.0;  // multiplies the whole image
  // Relative brightness change from one image edge to the opposite along the direction.
  double lighting_gradient = 0.0;
  double lighting_gradient_direction_rad = 0.0;  // in the image, from +u towards +v
  double vignetting = 0.0;      // relative darkening at the corners (cos^4-like falloff)
  double motion_blur_px = 0.0;  // blur length along travel in pixels; 0 = none
  double noise_sigma = 0.0;     // Gaussian sensor noise, 8-bit grey levels
  // Light direction for shading and highlights (from the surface to the light), belt frame.
  cv::Vec3d light_direction{-0.25, 0.2, 1.0};
};

// One fillet to render.
struct FilletInstance {
  double x_mm = 0.0;
  double y_mm = 0.0;
  double angle_rad = 0.0;   // thick end to tip, counter-clockwise from travel
  int shape_variant = 0;    // FilletRenderer shape (0 = the nominal mesh)
  int size_variant = 1;     // table 3.1 row: 0 = 144x72x40, 1 = 172x72x32, 2 = 176x72x40 mm
  double scale = 1.0;       // uniform size factor (real fillets spread, ~ +-5 %)
  Hand hand = Hand::kLeft;  // kLeft is the base mesh, kRight its mirror
  SideUp side = SideUp::kSkin;
  int group_id = -1;     // >= 0: fillets sharing it touch (one blob); ground truth only
  double lift_mm = 0.0;  // lying on another fillet: its surface this much higher (>= 0)
  // Curvature of the long axis in the belt plane, 1/mm (a limp fillet lies bent on the belt;
  // the DEM twin reports it, dem::InPlaneBendFit). The fillet's straight shape is laid along a
  // circular arc tangent to angle_rad at (x_mm, y_mm), so angle_rad stays the heading at the
  // pose point. Positive turns the tip anticlockwise. At most kMaxBendPerMm in magnitude.
  double bend_per_mm = 0.0;
};
// Tightest bend drawn: a 50 mm radius keeps the inner edge of a fillet of up to 1.2 times the
// 72 mm width outside the arc's centre. A fillet bent tighter is folded, which an arc in the
// belt plane cannot draw.
inline constexpr double kMaxBendPerMm = 1.0 / 50.0;

struct Scene {
  std::vector<FilletInstance> fillets;
  BeltAppearance belt;
  ImagingConditions imaging;
  std::uint64_t seed = 1;  // textures, colour jitter, grain and noise
  int supersampling = 2;   // samples per pixel per axis (anti-aliased edges)
};

// Ground truth for one fillet of a rendered frame.
struct FilletTruth {
  FilletInstance fillet;
  bool fully_visible = false;  // the whole silhouette lies inside the image (3 px margin)
  bool singulated = true;      // no other fillet shares its group
  // Least distance between its silhouette and another fillet's of the scene (0 where they
  // touch or overlap; infinity when it is alone). A pair closer than the vision's least gap
  // is meant to be reported not singulated although its silhouettes do not touch.
  double gap_to_nearest_mm = std::numeric_limits<double>::infinity();
  cv::Point2d centre_px;             // image position of the pose
  double silhouette_area_mm2 = 0.0;  // as laid on the belt, bent if it is
  // Belt position of the silhouette's area centroid (the pose is the volume centroid).
  cv::Point2d silhouette_centroid_mm;
};

struct RenderedFrame {
  cv::Mat bgr;  // CV_8UC3
  std::vector<FilletTruth> truth;
};

// A plain checkerboard (black and white squares, white margin) lying flat on the belt.
struct CheckerboardOnBelt {
  int inner_corners_x = 9;  // along the board's x axis
  int inner_corners_y = 6;
  double square_mm = 20.0;
  double margin_mm = 15.0;  // white border around the squares
  // Belt position of the board's first inner corner and the angle of its x axis.
  double origin_x_mm = 0.0;
  double origin_y_mm = 0.0;
  double yaw_rad = 0.0;
};
// The square at board cell (0, 0), the one diagonally outside the first inner corner, is black.
// Belt position of inner corner (i, j).
cv::Point2d checkerboard_corner_mm(const CheckerboardOnBelt& board, int i, int j);

class FilletRenderer {
 public:
  // Builds the height maps of the 3 sizes x 2 hands x 2 sides from the procedural mesh, for
  // `shape_variants` shapes: 0 is the nominal FilletShapeParams, the others draw every shape
  // parameter (thickness and width profiles, end caps, edge asymmetry, dome share) uniformly
  // within about +-25 % of nominal from `shape_seed` (about 0.3 s per shape).
  explicit FilletRenderer(int shape_variants = 1, std::uint64_t shape_seed = 1);
  ~FilletRenderer();
  FilletRenderer(FilletRenderer&&) noexcept;
  FilletRenderer& operator=(FilletRenderer&&) noexcept;

  RenderedFrame render(const RenderCamera& camera, const Scene& scene) const;
  cv::Mat render_checkerboard(const RenderCamera& camera, const CheckerboardOnBelt& board,
                              const BeltAppearance& belt, const ImagingConditions& imaging,
                              std::uint64_t seed) const;

  [[nodiscard]] int shape_variants() const;
  // Unscaled silhouette area of a size variant of the nominal shape (both hands and sides), mm^2.
  double silhouette_area_mm2(int size_variant) const;
  // Thick-end-to-tip length and width of a size variant, mm.
  cv::Size2d silhouette_size_mm(int size_variant) const;
  // Height of the fillet's top surface above the belt at a belt point; 0 outside it.
  double silhouette_height_mm(const FilletInstance& fillet, cv::Point2d belt_mm) const;
  // The fillet's silhouette boundary in belt millimetres.
  std::vector<cv::Point2d> silhouette_outline_mm(const FilletInstance& fillet) const;

 private:
  struct Sprites;
  std::unique_ptr<Sprites> sprites_;
};

// A second fillet lying side by side with `first`, touching it: turned by `relative_angle_rad`,
// shifted along `first`'s axis by `along_offset_mm`, and moved sideways (to the left when
// `to_the_left`) until the two silhouettes overlap by `overlap_mm` (a flattened contact).
// Both get the same group id. Uses the renderer's silhouettes.
FilletInstance make_touching_partner(const FilletRenderer& renderer, FilletInstance& first,
                                     FilletInstance partner_template, bool to_the_left,
                                     double relative_angle_rad, double along_offset_mm,
                                     double overlap_mm, int group_id);

// A second fillet lying partly on top of `first`, as one that slid onto its neighbour: placed
// as make_touching_partner with `overlap_mm` of overlap across the silhouettes, then lifted by
// the thickness of `first` under it, so its surface is the one seen where they overlap.
FilletInstance make_overlapping_partner(const FilletRenderer& renderer, FilletInstance& first,
                                        FilletInstance partner_template, bool to_the_left,
                                        double relative_angle_rad, double along_offset_mm,
                                        double overlap_mm, int group_id);

}  // namespace fl::render
