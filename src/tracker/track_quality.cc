#include "ekf_vislam/tracker/track_quality.h"

#include "ekf_vislam/core/median.h"
#include "ekf_vislam/tracker/rectified_stereo.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <optional>
#include <sstream>
#include <unordered_map>

namespace ekf_vislam {

namespace {

struct TrackStart {
  size_t frame = 0;
  Eigen::Vector3d p_world = Eigen::Vector3d::Zero();
  bool valid = false;
};

}  // namespace

TrackQuality evaluateTrackQuality(const std::vector<StereoFrame>& frames,
                                  const std::vector<Eigen::Matrix4d>& world_T_cam,
                                  const StereoCalibration& c, int max_age) {
  TrackQuality quality;
  std::unordered_map<uint32_t, TrackStart> starts;
  std::unordered_map<uint32_t, int> lengths;
  std::map<int, std::vector<double>> errors;
  size_t total = 0;
  quality.min_observations_per_frame =
      frames.empty() ? 0 : static_cast<int>(frames[0].features.size());
  for (size_t k = 0; k < frames.size() && k < world_T_cam.size(); ++k) {
    const Eigen::Matrix4d cam_T_world = world_T_cam[k].inverse();
    total += frames[k].features.size();
    quality.min_observations_per_frame =
        std::min(quality.min_observations_per_frame, static_cast<int>(frames[k].features.size()));
    for (const TrackedFeature& f : frames[k].features) {
      ++lengths[f.id];
      auto it = starts.find(f.id);
      if (it == starts.end()) {
        TrackStart start;
        start.frame = k;
        const std::optional<Eigen::Vector3d> p_cam = triangulate(c, f.left, f.left.x - f.right.x);
        if (p_cam) {
          const Eigen::Vector4d p_cam_h = p_cam->homogeneous();
          start.p_world = (world_T_cam[k] * p_cam_h).head<3>();
          start.valid = true;
        }
        starts.emplace(f.id, start);
        continue;
      }
      const int age = static_cast<int>(k - it->second.frame);
      if (!it->second.valid || age > max_age) continue;
      const Eigen::Vector3d p_cam = (cam_T_world * it->second.p_world.homogeneous()).head<3>();
      if (p_cam.z() <= 0) continue;
      const Eigen::Vector2d pixel = project(c, p_cam);
      const double du = pixel.x() - f.left.x;
      const double dv = pixel.y() - f.left.y;
      errors[age].push_back(std::hypot(du, dv));
    }
  }
  for (auto& [age, values] : errors) {
    quality.median_error_px[age] = median(&values);
    quality.samples[age] = static_cast<int>(values.size());
  }
  quality.num_tracks = static_cast<int>(lengths.size());
  double sum = 0;
  for (const auto& [id, length] : lengths) sum += length;
  quality.mean_track_length = lengths.empty() ? 0.0 : sum / lengths.size();
  quality.mean_observations_per_frame = frames.empty() ? 0.0 : double(total) / frames.size();
  return quality;
}

std::string TrackQuality::describe() const {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(3);
  s << "median reprojection error (left, px) by age:";
  for (const auto& [age, error] : median_error_px) {
    s << " " << age << ":" << error << "(n=" << samples.at(age) << ")";
  }
  s.precision(2);
  s << "\nobservations per frame: mean " << mean_observations_per_frame << ", min "
    << min_observations_per_frame << "; tracks " << num_tracks << ", mean track length "
    << mean_track_length << " frames";
  return s.str();
}

}  // namespace ekf_vislam
