#include "testing/synthetic_scenario.h"

#include "ekf_vislam/core/se3.h"
#include "ekf_vislam/core/stereo_camera.h"

#include <algorithm>
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
  // The drive's disparities are off by exactly this (0: exact), so that is what is counted.
  o.intrinsic.disparity_offset_counted_sigma = std::abs(scenario.disparity_offset_px);
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

namespace {

// One random stream for the drive, its landmarks and its tracks, drawn in that order (the
// distributions keep state between draws, so they travel with the engine). Where one expression
// draws twice, the compiler orders the draws; those expressions are kept as they were written
// first, so that every test's drive stays the one its bounds were measured on.
struct Random {
  explicit Random(uint32_t seed) : engine(seed) {}
  double normal() { return normal_distribution(engine); }
  double uniform() { return uniform_distribution(engine); }
  std::mt19937 engine;
  std::normal_distribution<double> normal_distribution{0.0, 1.0};
  std::uniform_real_distribution<double> uniform_distribution{0.0, 1.0};
};

// 1 on the road, 0 at rest during the stop, a half cosine over 20 frames on either side.
double movingFraction(const ScenarioOptions& o, int k) {
  if (o.stop_frames <= 0) return 1.0;
  constexpr double kRampFrames = 20.0;
  const double before = (o.stop_first_frame - k) / kRampFrames;
  const double after = (k - (o.stop_first_frame + o.stop_frames - 1)) / kRampFrames;
  const double level = std::clamp(std::max(before, after), 0.0, 1.0);
  return 0.5 - 0.5 * std::cos(M_PI * level);
}

// Trajectory: forward speed and yaw rate varying smoothly; index k+1 drives [t_k, t_k+1].
void drive(const ScenarioOptions& o, Random* random, Scenario* s) {
  const double phase = 2.0 * M_PI * random->uniform();
  Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
  for (int k = 0; k < o.frames; ++k) {
    const double t = k * o.dt;
    const double moving = movingFraction(o, k);
    TwistData truth;
    truth.stamp = 1000.0 + t;
    truth.v_imu =
        moving * Eigen::Vector3d(7.5 + 1.5 * std::sin(0.3 * t + phase), 0.0, 0.05 * std::sin(t));
    truth.w_imu = moving * Eigen::Vector3d(0.01 * std::sin(1.3 * t), 0.01 * std::cos(0.9 * t),
                                           0.18 * std::sin(2.0 * M_PI * t / 25.0 + phase));
    if (k > 0) {
      Vector6d xi;
      xi << truth.v_imu, truth.w_imu;
      T = T * se3::exp(o.dt * xi);
    }
    s->world_T_imu.push_back(T);
    s->true_twists.push_back(truth);
    s->still.push_back(k > 0 && moving == 0.0);
    TwistData measured = truth;
    for (int i = 0; i < 3; ++i) {
      measured.v_imu(i) += o.linear_velocity_noise * random->normal();
      measured.w_imu(i) += o.angular_velocity_noise * random->normal() + o.gyro_bias(i);
    }
    if (s->still.back()) measured.v_imu.setZero();
    s->twists.push_back(measured);
  }
  s->true_twists[0] = s->true_twists[1];
  s->true_twists[0].stamp = 1000.0;
}

// The accelerometer's samples along the drive, from a stream of their own (the other noises stay
// those of the drive without an accelerometer).
void accelerometer(const ScenarioOptions& o, Scenario* s) {
  std::mt19937 accel_rng(o.seed + 7919);
  std::normal_distribution<double> normal(0.0, 1.0);
  const Eigen::Vector3d up = o.up_world.normalized();
  // The accelerometer's own velocity, v + w^ r.
  auto accelVelocity = [&](const TwistData& u) {
    return Eigen::Vector3d(u.v_imu + u.w_imu.cross(o.accel_lever_arm));
  };
  for (size_t k = 0; k < s->world_T_imu.size(); ++k) {
    const size_t j = std::max<size_t>(k, 1);  // sample 0 repeats sample 1
    const Eigen::Matrix3d R = s->world_T_imu[j].topLeftCorner<3, 3>();
    const Eigen::Matrix3d R_previous = s->world_T_imu[j - 1].topLeftCorner<3, 3>();
    const Eigen::Vector3d a_world =
        (R * accelVelocity(s->true_twists[j]) - R_previous * accelVelocity(s->true_twists[j - 1])) /
        o.dt;
    AccelerometerData sample;
    sample.stamp = s->twists[k].stamp;
    sample.p_accel_in_imu = o.accel_lever_arm;
    sample.f_imu = R.transpose() * (a_world + 9.80665 * up) + o.accel_bias;
    for (int i = 0; i < 3; ++i) sample.f_imu(i) += o.accel_noise * normal(accel_rng);
    s->accels.push_back(sample);
  }
}

// Landmarks along both sides of the path, two per pose.
std::vector<Eigen::Vector3d> landmarksAlongThePath(const Scenario& s, Random* random) {
  std::vector<Eigen::Vector3d> points;
  for (size_t k = 0; k < s.world_T_imu.size(); ++k) {
    for (int n = 0; n < 2; ++n) {
      const double side = random->uniform() < 0.5 ? -1.0 : 1.0;
      const Eigen::Vector4d p_imu(40.0 * random->uniform(), side * (3.0 + 17.0 * random->uniform()),
                                  -1.5 + 6.5 * random->uniform(), 1.0);
      points.push_back((s.world_T_imu[k] * p_imu).head<3>());
    }
  }
  return points;
}

// The observations of each track with their pixel errors: e_k = rho e_(k-1) + sqrt(1 - rho^2)
// sigma n_k, e_0 = sigma n_0, plus the random-walk part (pixel_random_walk).
class TrackNoise {
 public:
  TrackNoise(const ScenarioOptions& o, Random* random) : o_(o), random_(random) {}

  /// still: the camera has not moved since the last frame (the track keeps its error).
  StereoObservation observe(uint32_t id, const Eigen::Vector4d& z, bool still = false) {
    auto [it, first] = pixel_error_.try_emplace(id, Eigen::Vector4d::Zero());
    Eigen::Vector4d& e = it->second;
    const double innovation = std::sqrt(1.0 - o_.pixel_correlation * o_.pixel_correlation);
    const double scale = first ? 1.0 : innovation;
    for (int i = 0; i < 4; ++i) {
      if (still && !first) {
        e(i) += o_.rest_pixel_jitter * random_->normal();
      } else {
        e(i) = o_.pixel_correlation * e(i) + scale * o_.pixel_sigma * random_->normal();
      }
    }
    Eigen::Vector4d error = e;
    if (o_.pixel_random_walk > 0.0) {
      // u and v step, shared by both images.
      Eigen::Vector2d& walk = pixel_walk_.try_emplace(id, Eigen::Vector2d::Zero()).first->second;
      if (!first) {
        walk += o_.pixel_random_walk * std::sqrt(o_.dt) *
                Eigen::Vector2d(random_->normal(), random_->normal());
      }
      error += Eigen::Vector4d(walk(0), walk(1), walk(0), walk(1));
    }
    StereoObservation f;
    f.id = id;
    f.u_left = z(0) + error(0);
    f.v_left = z(1) + error(1);
    f.u_right = z(2) - o_.disparity_offset_px + error(2);
    f.v_right = z(3) + error(3);
    return f;
  }

 private:
  const ScenarioOptions& o_;
  Random* random_;
  std::map<uint32_t, Eigen::Vector4d> pixel_error_;
  std::map<uint32_t, Eigen::Vector2d> pixel_walk_;
};

// Moves some of the frame's observations to random image positions (outlier_rate).
void addOutliers(double outlier_rate, Random* random, FeatureFrame* frame) {
  for (StereoObservation& f : frame->features) {
    if (!(random->uniform() < outlier_rate)) continue;
    f.u_left += (random->uniform() < 0.5 ? -1 : 1) * (20.0 + 100.0 * random->uniform());
    f.v_left += (random->uniform() < 0.5 ? -1 : 1) * (20.0 + 100.0 * random->uniform());
    f.v_right = f.v_left;
  }
}

// Tracks: an id per contiguous run; a point is tracked at most once, until it leaves the view or
// is lost (4 % per frame while moving); new tracks fill up to target_observations per frame.
void track(const ScenarioOptions& o, const std::vector<Eigen::Vector3d>& points, Random* random,
           Scenario* s) {
  const StereoCamera camera(s->calibration);
  std::vector<int> state(points.size(), 0);  // 0 unused, 1 tracking, 2 done
  std::vector<uint32_t> id_of(points.size(), 0);
  uint32_t next_id = 0;
  std::map<uint32_t, double> track_start;  ///< stamp of each track's first observation
  TrackNoise noise(o, random);
  for (size_t k = 0; k < s->world_T_imu.size(); ++k) {
    FeatureFrame frame;
    frame.stamp = s->twists[k].stamp;
    const Eigen::Matrix4d imu_T_world = se3::inverse(s->world_T_imu[k]);
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
        // A tracker does not lose a track on a view that does not change (a stop).
        if (!visible || (!s->still[k] && random->uniform() < 0.04)) {
          state[i] = 2;
          continue;
        }
        ++tracked;
        const double age = frame.stamp - track_start[id_of[i]];
        if (!o.track_drift_rate_imu.isZero(0.0)) {
          camera.projectTurned(imu_T_world, points[i], age * o.track_drift_rate_imu, &z, nullptr,
                               nullptr);
        }
        frame.features.push_back(noise.observe(id_of[i], z, s->still[k]));
      } else if (visible) {
        visible_new.emplace_back(i, z);
      }
    }
    for (const auto& [i, z] : visible_new) {
      if (tracked >= o.target_observations) break;
      if (random->uniform() > 0.5) continue;
      state[i] = 1;
      id_of[i] = next_id++;
      s->p_world[id_of[i]] = points[i];
      track_start[id_of[i]] = frame.stamp;
      ++tracked;
      frame.features.push_back(noise.observe(id_of[i], z));
    }
    addOutliers(o.outlier_rate, random, &frame);
    s->frames.push_back(frame);
  }
}

}  // namespace

Scenario makeScenario(const ScenarioOptions& o) {
  Random random(o.seed);
  Scenario s;
  s.calibration = kittiLikeCalibration();
  drive(o, &random, &s);
  if (o.accel_noise >= 0.0) accelerometer(o, &s);
  const std::vector<Eigen::Vector3d> points = landmarksAlongThePath(s, &random);
  track(o, points, &random, &s);
  return s;
}

}  // namespace testing
}  // namespace ekf_vislam
