// A fillet's spheres against its template: rigid rotation and in-plane bend
// (fl/twin/dem/fillet_bend.hpp).
#include "fl/twin/dem/fillet_bend.hpp"

#include <Eigen/Dense>
#include <cmath>

namespace fl::dem {
namespace {

// The body axis' horizontal share below which it has no usable heading: sin(6 degrees).
constexpr double kLeastHorizontalShare = 0.1;
// Spheres must spread this far along the axis (standard deviation) for a curvature to mean
// anything: under it the quadratic term is noise.
constexpr double kLeastAlongSpreadM = 0.002;

}  // namespace

Eigen::Matrix3d TemplateRotationFit::rotation() const {
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(h_, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  d(2, 2) = (svd.matrixV() * svd.matrixU().transpose()).determinant() < 0.0 ? -1.0 : 1.0;
  return svd.matrixV() * d * svd.matrixU().transpose();
}

InPlaneBendFit::InPlaneBendFit(const Eigen::Matrix3d& rotation) : rotation_(rotation) {
  const Eigen::Vector2d axis(rotation(0, 0), rotation(1, 0));
  const double norm = axis.norm();
  has_heading_ = norm >= kLeastHorizontalShare;
  if (has_heading_) {
    along_ = axis / norm;
    across_ = Eigen::Vector2d(-along_.y(), along_.x());
  }
}

void InPlaneBendFit::add(const Eigen::Vector3d& template_m,
                         const Eigen::Vector3d& world_from_centroid_m) {
  const Eigen::Vector3d rigid = rotation_ * template_m;
  const double u = along_.dot(rigid.head<2>());
  const double w = across_.dot((world_from_centroid_m - rigid).head<2>());
  double power = 1.0;
  for (int p = 0; p < 5; ++p) {
    sum_u_pow_[p] += power;
    if (p < 3) sum_w_u_pow_[p] += w * power;
    power *= u;
  }
}

double InPlaneBendFit::curvature_per_m() const {
  const double n = sum_u_pow_[0];
  if (!has_heading_ || n < 3.0) return 0.0;
  const double mean_u = sum_u_pow_[1] / n;
  const double variance_u = sum_u_pow_[2] / n - mean_u * mean_u;
  if (!(variance_u >= kLeastAlongSpreadM * kLeastAlongSpreadM)) return 0.0;
  Eigen::Matrix3d normal;
  Eigen::Vector3d rhs;
  for (int row = 0; row < 3; ++row) {
    for (int col = 0; col < 3; ++col) normal(row, col) = sum_u_pow_[row + col];
    rhs(row) = sum_w_u_pow_[row];
  }
  const Eigen::Vector3d coefficients = normal.ldlt().solve(rhs);
  const double curvature = 2.0 * coefficients(2);
  return std::isfinite(curvature) ? curvature : 0.0;
}

}  // namespace fl::dem
