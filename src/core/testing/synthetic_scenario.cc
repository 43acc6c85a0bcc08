#include "testing/synthetic_scenario.h"

#include "ekf_vislam/core/se3.h"
#include "ekf_vislam/core/stereo_camera.h"

#include <cmath>
#include <random>

namespace ekf_vislam {
namespace testing {

VislamOptions matchedOptions(const ScenarioOptions& scenario) {
  VislamOptions o;
  o.noise.pixel_sigma = scenario.pixel_sigma;
  o.noise.pixel_correlation = scenario.pixel_correlation;
  o.noise.track_random_walk = scenario.pixel_random_walk;
  o.noise.linear_velocity_noise = scenario.linear_velocity_noise * std::sqrt(scenario.dt);
  o.noise.angular_velocity_noise = scenario.angular_velocity_noise * std::sqrt(scenario.dt);
  o.landmarks.max_track_length = 0;
  return o;
}

StereoCalibration kittiLikeCalibration() {
  StereoCalibration c;
  c.fx = c.fy = 707.0912;
  c.cx = 601.8873;
  c.cy = 183.1104;
  c.baseline = 0.5371506532679237;
  c.image_width = 1241;
  c.image_height = 376;
  Eigen::Matrix3d R;
  R << 0, -1, 0, 0, 0, -1, 1, 0, 0;
  c.cam_T_imu.linear() = R;
  c.cam_T_imu.translation() = Eigen::Vector3d(-0.3164, 0.7341, -1.1380);
  return c;
}

Scenario makeScenario(const ScenarioOptions& o) {
  std::mt19937 rng(o.seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  Scenario s;
  s.calibration = kittiLikeCalibration();
  const StereoCamera camera(s.calibration);

  // Trajectory: forward speed and yaw rate varying smoothly; index k+1 drives [t_k, t_k+1].
  const double phase = 2.0 * M_PI * uniform(rng);
  Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
  for (int k = 0; k < o.frames; ++k) {
    const double t = k * o.dt;
    TwistData truth;
    truth.stamp = 1000.0 + t;
    truth.v_imu = Eigen::Vector3d(7.5 + 1.5 * std::sin(0.3 * t + phase), 0.0, 0.05 * std::sin(t));
    truth.w_imu = Eigen::Vector3d(0.01 * std::sin(1.3 * t), 0.01 * std::cos(0.9 * t),
                                  0.18 * std::sin(2.0 * M_PI * t / 25.0 + phase));
    if (k > 0) {
      Vector6d xi;
      xi << truth.v_imu, truth.w_imu;
      T = T * se3::exp(o.dt * xi);
    }
    s.world_T_imu.push_back(T);
    s.true_twists.push_back(truth);
    TwistData measured = truth;
    for (int i = 0; i < 3; ++i) {
      measured.v_imu(i) += o.linear_velocity_noise * normal(rng);
      measured.w_imu(i) += o.angular_velocity_noise * normal(rng) + o.gyro_bias(i);
    }
    s.twists.push_back(measured);
  }
  s.true_twists[0] = s.true_twists[1];
  s.true_twists[0].stamp = 1000.0;
  if (o.accel_noise >= 0.0) {
    // Its own stream: the other noises stay those of the drive without an accelerometer.
    std::mt19937 accel_rng(o.seed + 7919);
    const Eigen::Vector3d up = o.up_world.normalized();
    for (size_t k = 0; k < s.world_T_imu.size(); ++k) {
      const size_t j = std::max<size_t>(k, 1);  // sample 0 repeats sample 1
      const Eigen::Matrix3d R = s.world_T_imu[j].topLeftCorner<3, 3>();
      const Eigen::Matrix3d R_previous = s.world_T_imu[j - 1].topLeftCorner<3, 3>();
      // The accelerometer's own velocity, v + w^ r.
      auto accelVelocity = [&](const TwistData& u) {
        return Eigen::Vector3d(u.v_imu + u.w_imu.cross(o.accel_lever_arm));
      };
      const Eigen::Vector3d a_world =
          (R * accelVelocity(s.true_twists[j]) - R_previous * accelVelocity(s.true_twists[j - 1])) /
          o.dt;
      AccelerometerData sample;
      sample.stamp = s.twists[k].stamp;
      sample.p_accel_in_imu = o.accel_lever_arm;
      sample.f_imu = R.transpose() * (a_world + 9.80665 * up) + o.accel_bias;
      for (int i = 0; i < 3; ++i) sample.f_imu(i) += o.accel_noise * normal(accel_rng);
      s.accels.push_back(sample);
    }
  }

  // Landmarks along both sides of the path.
  std::vector<Eigen::Vector3d> points;
  for (size_t k = 0; k < s.world_T_imu.size(); k += 1) {
    for (int n = 0; n < 2; ++n) {
      const double side = uniform(rng) < 0.5 ? -1.0 : 1.0;
      const Eigen::Vector4d p_imu(40.0 * uniform(rng), side * (3.0 + 17.0 * uniform(rng)),
                                  -1.5 + 6.5 * uniform(rng), 1.0);
      points.push_back((s.world_T_imu[k] * p_imu).head<3>());
    }
  }

  // Tracks: an id per contiguous run; a point is tracked at most once.
  std::vector<int> state(points.size(), 0);  // 0 unused, 1 tracking, 2 done
  std::vector<uint32_t> id_of(points.size(), 0);
  uint32_t next_id = 0;
  // Pixel error of each track: e_k = rho e_(k-1) + sqrt(1 - rho^2) sigma n_k, e_0 = sigma n_0.
  std::map<uint32_t, Eigen::Vector4d> pixel_error;
  std::map<uint32_t, Eigen::Vector2d> pixel_walk;  ///< random-walk part (pixel_random_walk)
  std::map<uint32_t, double> track_start;          ///< stamp of each track's first observation
  const double innovation = std::sqrt(1.0 - o.pixel_correlation * o.pixel_correlation);
  auto observe = [&](uint32_t id, const Eigen::Vector4d& z) {
    auto [it, first] = pixel_error.try_emplace(id, Eigen::Vector4d::Zero());
    Eigen::Vector4d& e = it->second;
    const double scale = first ? 1.0 : innovation;
    for (int i = 0; i < 4; ++i) {
      e(i) = o.pixel_correlation * e(i) + scale * o.pixel_sigma * normal(rng);
    }
    Eigen::Vector4d error = e;
    if (o.pixel_random_walk > 0.0) {
      // u and v step, shared by both images.
      Eigen::Vector2d& walk = pixel_walk.try_emplace(id, Eigen::Vector2d::Zero()).first->second;
      if (!first) {
        walk += o.pixel_random_walk * std::sqrt(o.dt) * Eigen::Vector2d(normal(rng), normal(rng));
      }
      error += Eigen::Vector4d(walk(0), walk(1), walk(0), walk(1));
    }
    StereoObservation f;
    f.id = id;
    f.u_left = z(0) + error(0);
    f.v_left = z(1) + error(1);
    f.u_right = z(2) - o.disparity_offset_px + error(2);
    f.v_right = z(3) + error(3);
    return f;
  };
  for (size_t k = 0; k < s.world_T_imu.size(); ++k) {
    FeatureFrame frame;
    frame.stamp = s.twists[k].stamp;
    const Eigen::Matrix4d imu_T_world = se3::inverse(s.world_T_imu[k]);
    int tracked = 0;
    std::vector<std::pair<size_t, Eigen::Vector4d>> visible_new;
    for (size_t i = 0; i < points.size(); ++i) {
      if (state[i] == 2) continue;
      Eigen::Vector4d z;
      const Eigen::Vector4d p_cam = camera.camTImu() * imu_T_world * points[i].homogeneous();
      const bool visible = camera.project(imu_T_world, points[i], &z) && p_cam.z() > 2.0 &&
                           p_cam.z() < 50.0 && camera.inImage(z(0), z(1)) &&
                           camera.inImage(z(2), z(3)) && z(0) - z(2) > 0.5;
      if (state[i] == 1) {
        if (!visible || uniform(rng) < 0.04) {
          state[i] = 2;
          continue;
        }
        ++tracked;
        const double age = frame.stamp - track_start[id_of[i]];
        if (!o.track_drift_rate_imu.isZero(0.0)) {
          camera.projectTurned(imu_T_world, points[i], age * o.track_drift_rate_imu, &z, nullptr,
                               nullptr);
        }
        frame.features.push_back(observe(id_of[i], z));
      } else if (visible) {
        visible_new.emplace_back(i, z);
      }
    }
    for (const auto& [i, z] : visible_new) {
      if (tracked >= o.target_observations) break;
      if (uniform(rng) > 0.5) continue;
      state[i] = 1;
      id_of[i] = next_id++;
      s.p_world[id_of[i]] = points[i];
      track_start[id_of[i]] = frame.stamp;
      ++tracked;
      frame.features.push_back(observe(id_of[i], z));
    }
    for (StereoObservation& f : frame.features) {
      if (uniform(rng) < o.outlier_rate) {
        f.u_left += (uniform(rng) < 0.5 ? -1 : 1) * (20.0 + 100.0 * uniform(rng));
        f.v_left += (uniform(rng) < 0.5 ? -1 : 1) * (20.0 + 100.0 * uniform(rng));
        f.v_right = f.v_left;
      }
    }
    s.frames.push_back(frame);
  }
  return s;
}

}  // namespace testing
}  // namespace ekf_vislam
