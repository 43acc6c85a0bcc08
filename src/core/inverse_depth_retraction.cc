#include "ekf_vislam/core/inverse_depth_retraction.h"

namespace ekf_vislam {
namespace inverse_depth_retraction {

Eigen::Vector3d move(const Eigen::Vector3d& q_cam, const Eigen::Vector3d& dq_cam,
                     double min_depth) {
  const Eigen::Vector3d cartesian = q_cam + dq_cam;
  if (!(q_cam.z() >= min_depth)) return cartesian;
  const double r = 1.0 / q_cam.z();
  const double a = q_cam.x() * r;
  const double b = q_cam.y() * r;
  // q = (a, b, 1) / r: dq = (da - a dr / r, db - b dr / r, -dr / r) / r, inverted.
  const double dr = -r * r * dq_cam.z();
  const double da = r * dq_cam.x() - a * r * dq_cam.z();
  const double db = r * dq_cam.y() - b * r * dq_cam.z();
  const double r_moved = r + dr;
  if (!(r_moved > 0.2 * r)) return cartesian;
  return Eigen::Vector3d(a + da, b + db, 1.0) / r_moved;
}

}  // namespace inverse_depth_retraction
}  // namespace ekf_vislam
