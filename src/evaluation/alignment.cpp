/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/evaluation/alignment.h>

#include <Eigen/LU>
#include <Eigen/SVD>

#include <stdexcept>

namespace pcl_parallel {
namespace evaluation {

std::string
toString(Alignment a)
{
  switch (a) {
  case Alignment::None:
    return "none";
  case Alignment::SE3:
    return "se3";
  case Alignment::Sim3:
    return "sim3";
  }
  return "?";
}

Alignment
alignmentFromString(const std::string& s)
{
  if (s == "none")
    return Alignment::None;
  if (s == "se3")
    return Alignment::SE3;
  if (s == "sim3")
    return Alignment::Sim3;
  throw std::invalid_argument("unknown alignment \"" + s + "\" (none, se3 or sim3)");
}

Eigen::Matrix4d
Similarity::apply(const Eigen::Matrix4d& pose) const
{
  Eigen::Matrix4d out = Eigen::Matrix4d::Identity();
  out.topLeftCorner<3, 3>() = rotation * pose.topLeftCorner<3, 3>();
  out.topRightCorner<3, 1>() = scale * (rotation * pose.topRightCorner<3, 1>()) + translation;
  return out;
}

Similarity
umeyamaAlignment(const Poses& estimate, const Poses& reference, bool with_scale)
{
  if (estimate.size() != reference.size() || estimate.empty())
    throw std::invalid_argument("pcl_parallel::evaluation::umeyamaAlignment: needs two "
                                "equally long, non-empty pose lists");
  const double n = static_cast<double>(estimate.size());
  Eigen::Vector3d mean_x = Eigen::Vector3d::Zero(), mean_y = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < estimate.size(); ++i) { // Eq. 34, 35
    mean_x += estimate[i].topRightCorner<3, 1>();
    mean_y += reference[i].topRightCorner<3, 1>();
  }
  mean_x /= n;
  mean_y /= n;
  double sigma_x = 0.0;                          // Eq. 36
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero(); // Eq. 38
  for (std::size_t i = 0; i < estimate.size(); ++i) {
    const Eigen::Vector3d x = estimate[i].topRightCorner<3, 1>() - mean_x;
    const Eigen::Vector3d y = reference[i].topRightCorner<3, 1>() - mean_y;
    sigma_x += x.squaredNorm();
    cov += y * x.transpose();
  }
  sigma_x /= n;
  cov /= n;
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(cov, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Vector3d d = svd.singularValues();
  // evo counts singular values above machine epsilon; relative to the largest here, so the
  // test does not depend on the unit of the positions.
  if (!(d(1) > 1e-12 * d(0)))
    throw std::invalid_argument(
        "pcl_parallel::evaluation: cannot align the trajectories: the positions lie on one "
        "line (or coincide), so the rotation is not determined; use no alignment "
        "(evaluate: --align none)");
  Eigen::Matrix3d s = Eigen::Matrix3d::Identity(); // Eq. 43: a rotation, not a reflection
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0.0)
    s(2, 2) = -1.0;
  Similarity sim;
  sim.rotation = svd.matrixU() * s * svd.matrixV().transpose(); // Eq. 40
  if (with_scale) {
    if (!(sigma_x > 0.0))
      throw std::invalid_argument("pcl_parallel::evaluation: cannot estimate the scale: the "
                                  "estimate's positions all coincide");
    sim.scale = (d.asDiagonal() * s).trace() / sigma_x; // Eq. 42
  }
  sim.translation = mean_y - sim.scale * sim.rotation * mean_x; // Eq. 41
  return sim;
}

Similarity
alignTrajectory(const Poses& estimate, const Poses& reference, Alignment alignment)
{
  if (alignment == Alignment::None)
    return Similarity();
  return umeyamaAlignment(estimate, reference, alignment == Alignment::Sim3);
}

} // namespace evaluation
} // namespace pcl_parallel
