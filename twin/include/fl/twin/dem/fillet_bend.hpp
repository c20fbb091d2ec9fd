// A fillet's spheres measured against its template: the rigid rotation that lays the template
// onto them (TemplateRotationFit), and how far its long axis is bent in the belt plane, as a
// top-down camera sees it (InPlaneBendFit: the curvature of a circular arc through its spheres,
// measured against where the rigid fit puts them). The DEM plant and the bulk scene read a
// fillet's pose so; the camera renderer draws the fillet as the engine bent it.
#pragma once

#include <Eigen/Core>
#include <cstddef>

namespace fl::dem {

// Least-squares rotation of a template onto its spheres (Kabsch): H = sum p (x - c)^T over the
// template positions p and the spheres' world positions x about their centroid c; the rotation
// V diag(1, 1, det) U^T of H's SVD is a proper one (no mirror). Body x runs from the thick end
// to the tip and body z is the skin side's normal, so the rotation's first column is the
// heading and its (2, 2) entry says which side is up.
class TemplateRotationFit {
 public:
  // One sphere: its template position and its world position about the spheres' centroid.
  void add(const Eigen::Vector3d& template_m, const Eigen::Vector3d& world_from_centroid_m) {
    h_ += template_m * world_from_centroid_m.transpose();
  }
  // Template coordinates to world ones.
  [[nodiscard]] Eigen::Matrix3d rotation() const;

 private:
  Eigen::Matrix3d h_ = Eigen::Matrix3d::Zero();
};

// Least-squares fit of the spheres' sideways deviation from the rigid fit, w = a + b u + c u^2
// over the position u along the axis, both measured in the horizontal plane (world x, y): an
// arc of curvature k deviates by k u^2 / 2 from its tangent, so k = 2 c. Positive k turns the
// axis anticlockwise seen from above (+z) as it runs from the thick end to the tip.
class InPlaneBendFit {
 public:
  // `rotation` takes template coordinates (x from the thick end to the tip) to world ones.
  explicit InPlaneBendFit(const Eigen::Matrix3d& rotation);

  // One sphere: its template position and its world position, both about their centroids.
  void add(const Eigen::Vector3d& template_m, const Eigen::Vector3d& world_from_centroid_m);

  // 1/m. Zero where the fit has no answer: an axis standing within about 6 degrees of vertical
  // (no heading to bend in the plane), or spheres spread along under 2 mm of the axis.
  [[nodiscard]] double curvature_per_m() const;

 private:
  Eigen::Matrix3d rotation_;
  Eigen::Vector2d along_ = Eigen::Vector2d::UnitX();
  Eigen::Vector2d across_ = Eigen::Vector2d::UnitY();
  bool has_heading_ = false;
  // Normal equations of the quadratic: sums of u^0..u^4 and of w u^0..u^2.
  double sum_u_pow_[5] = {};
  double sum_w_u_pow_[3] = {};
};

}  // namespace fl::dem
