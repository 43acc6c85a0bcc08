"""A KITTI-like stereo visual-inertial driving simulator writing course datasets (2019 layout).

`simulate(seed, **options)` returns a dict of arrays (the dataset, the true poses and twists,
the noiseless observations and the landmarks); `write_outputs(result, prefix)` writes
``PREFIX.npz`` (2019 layout, with a correct cam_T_imu and the keys
``cam_T_imu_translation_correct = True`` and ``image_size``), ``PREFIX_groundtruth.tum``
(world_T_imu per frame, first pose = identity) and ``PREFIX_landmarks.csv`` (``id,x,y,z``, world).

Conventions (those of the estimator): body/IMU frame x forward, y left, z up; the twist stored at
index k+1 is the constant body twist over [t_k, t_k+1]:

    world_T_imu[k+1] = world_T_imu[k] @ twist_exp(v_true[:, k+1], w_true[:, k+1], t[k+1] - t[k])

and index 0 holds the same as index 1. Everything is deterministic from the seed: independent
random streams (trajectory, landmarks, tracking, pixel noise, gyro offset, twist noise,
accelerometer noise) are spawned from ``numpy.random.SeedSequence(seed)``, so changing a noise
option leaves the geometry (and the other noises) unchanged.

Accelerometer (only with the option accel_noise; without it there is no ``specific_force`` at all):
sample k (m/s^2, IMU/body frame) is the mean specific force over (t_k-1, t_k] expressed in the body
frame at t_k (see `specific_force`), plus a constant bias and white noise. The world frame is the
first pose, not the level: gravity's "up" in it is ``up_world`` = R0^T e3, R0 the vehicle's
attitude against the level at the first frame (its roll and pitch, yaw 0).
"""
import collections
import heapq
import math

import numpy as np
from scipy.interpolate import PchipInterpolator
from scipy.spatial import cKDTree

from ekf_vislam_tools import se3, stereo_geometry, traffic, trajectory
from ekf_vislam_tools.dataset import TRANSLATION_CORRECT_KEY, UNOBSERVED, observed_mask

# KITTI odometry sequence 07 calibration (rectified gray cameras, IMU -> cam0).
KITTI_K = np.array([[707.0912, 0.0, 601.8873],
                    [0.0, 707.0912, 183.1104],
                    [0.0, 0.0, 1.0]])
KITTI_BASELINE = 0.5371506532679237
KITTI_IMAGE_SIZE = (1241, 376)
KITTI_CAM_T_IMU = np.array([[0.0, -1.0, 0.0, -0.3164],
                            [0.0, 0.0, -1.0, 0.7341],
                            [1.0, 0.0, 0.0, -1.1380],
                            [0.0, 0.0, 0.0, 1.0]])

DEFAULT_OPTIONS = {
    # Drive
    'frames': 800,             # number of frames (ignored when length_m is given)
    'length_m': None,          # drive this many metres instead of a number of frames
    'rate_hz': 10.0,           # frame rate
    'time_jitter': 0.001,      # frame interval jitter, uniform +-, s
    'start_time': 1.3e9,       # first time stamp, s
    'speed_min': 5.0,          # forward speed range, m/s
    'speed_max': 10.0,
    'max_yaw_rate': 0.3,       # peak yaw rate of the sharpest turns, rad/s
    'roll_amplitude': 1.0,     # peak roll of the vehicle against the level, deg (smooth, 8-30 s)
    'pitch_amplitude': 1.5,    # peak pitch, deg (smooth, periods 10-40 s): hills and dips
    'stops': (),               # (start s, duration s) pairs: the vehicle slows to a halt over
                               # STOP_RAMP_S before start and waits `duration` (traffic lights);
                               # at rest the measured linear velocity is exactly 0 (a wheel
                               # odometry), the gyro keeps its noise and offset, and each track
                               # keeps its pixel error (the same view gives the same track) but
                               # for rest_pixel_jitter
    'rest_pixel_jitter': 0.02,  # px, white noise on each coordinate of a track at rest (the
                               # image sensor's noise moves a tracked corner by hundredths)
    # Scene and tracking
    'landmark_density': 5.0,   # landmarks per metre of road (both sides together)
    'target_obs': 70,          # observations per frame the tracker aims at (varies +-25 %)
    'track_loss': 0.05,        # per-frame probability that a track is lost while still visible
    'reuse_ids_after': 0,      # 0: every track gets a new id; N > 0: the id of a track that ended
                               # is given to a new track once unseen for N frames (bounds the
                               # (4,M,T) features array of long drives; landmarks.csv then holds
                               # the last point of each id)
    'min_depth': 2.0,          # observable depth range, m
    'max_depth': 60.0,
    'min_disparity': 0.5,      # px
    'vehicles_ahead': 0,       # traffic: cars driving ahead of the ego vehicle, their corners
                               # tracked too (they move with it: ekf_vislam_tools.traffic)
    'oncoming_per_minute': 0.0,  # traffic: oncoming cars per minute in the lane to the left
    # Noise
    'pixel_noise': 1.0,        # std of each pixel coordinate, px
    'pixel_correlation': 0.0,  # drifting tracks: a track's pixel error is AR(1) with this
                               # correlation from one frame to the next (std pixel_noise); 0: white
    'drift_expansion': 0.0,    # systematic drift of the tracks, as measured on the KITTI course
                               # tracks (0.18-0.28): px per frame of age per unit of normalized
                               # image x, added to u_left and u_right (an outward drift that also
                               # grows the disparity); 0: none
    'disparity_offset': 0.0,   # px, measured minus true disparity: every u_right moved left by
                               # it (a rig whose rectification disagrees with its images, KITTI's
                               # 0.23-1.39 px); 0: exact
    'drift_v': 0.0,            # px per frame of age added to v (KITTI course tracks: -0.04 to
                               # -0.06, upward); 0: none
    'outlier_rate': 0.03,      # fraction of observations replaced by gross outliers
    'velocity_noise': 0.5,     # std of each linear velocity component, m/s
    'gyro_noise': 0.05,        # std of each angular velocity component, rad/s
    'gyro_bias': None,         # constant gyro offset: None = drawn from the seed, a scalar or 3
    'accel_noise': None,       # accelerometer: std of each specific force component per sample,
                               # m/s^2; None = no accelerometer (no specific_force at all)
    'accel_bias': 0.0,         # constant accelerometer offset, m/s^2: a scalar or 3 (body axes)
}

#: Standard gravity, m/s^2.
GRAVITY = 9.80665

#: Seconds a stop takes to slow down to rest, and to speed up again after it.
STOP_RAMP_S = 3.0

# New streams go at the end: the children of a SeedSequence do not depend on how many are
# spawned, so the existing streams (and every existing drive) stay the same.
_STREAMS = ('trajectory', 'landmarks', 'tracking', 'noise', 'gyro_bias', 'twist_noise', 'accel',
            'traffic', 'traffic_noise')


def simulate(seed, **options):
    """Simulate a drive -> dict of arrays.

    Dataset: 't' (T,), 'features' (4,M,T) with -1 where unobserved, 'linear_velocity' and
    'rotational_velocity' (3,T) as measured, 'K', 'b', 'cam_T_imu' (correct), 'image_size'.
    Truth: 'world_T_imu' (T,4,4) with the first pose the identity, 'v_true', 'w_true' (3,T),
    'features_true' (4,M,T, noiseless), 'outlier_mask' (M,T), 'landmarks' (M,3) world position of
    each feature id (a car's corner: where it was first seen), 'landmark_points' (L,3) all the
    static points, 'point_of_id' (M,) (-1: a corner on a car, which moves),
    'gyro_bias' (3,), 'path_length' (m), 'options' (the options used).
    With accel_noise: 'specific_force' (3,T) as measured (m/s^2, body frame, bias and noise
    included), and the truth 'up_world' (3,) (unit "up", against gravity, in world axes) and
    'accel_bias' (3,).
    """
    unknown = set(options) - set(DEFAULT_OPTIONS)
    if unknown:
        raise TypeError('simulate(): unknown options %s' % ', '.join(sorted(unknown)))
    opts = dict(DEFAULT_OPTIONS)
    opts.update({k: v for k, v in options.items() if v is not None})
    _check_options(opts)
    rngs = {name: np.random.default_rng(child) for name, child in
            zip(_STREAMS, np.random.SeedSequence(seed).spawn(len(_STREAMS)))}

    t, v_true, w_true, world_T_imu, up_world, at_rest = _drive(rngs['trajectory'], opts)
    path_length = float(travelled_distance(world_T_imu)[-1])
    points = _landmark_points(rngs['landmarks'], world_T_imu, opts)
    obs_frame, obs_point, obs_id, z_true = _track(rngs['tracking'], points, world_T_imu, opts)
    z_meas, is_outlier = _measure_pixels(rngs['noise'], z_true, obs_frame, obs_id, opts,
                                         still=at_rest)

    num_static = int(obs_id.max()) + 1 if obs_id.size else 0
    point_of_id = np.zeros(num_static, dtype=np.int64)
    point_of_id[obs_id] = obs_point
    landmarks = points[point_of_id]
    if opts['vehicles_ahead'] or opts['oncoming_per_minute']:
        car = _vehicle_observations(rngs['traffic'], rngs['traffic_noise'], t, world_T_imu, opts)
        obs_frame, obs_id, z_true, z_meas, is_outlier = (
            np.concatenate(pair) for pair in zip(
                (obs_frame, obs_id, z_true, z_meas, is_outlier),
                (car['frame'], car['id'] + num_static, car['z_true'], car['z'],
                 car['is_outlier'])))
        landmarks = np.concatenate([landmarks, car['first_position']])
        point_of_id = np.concatenate([point_of_id, np.full(len(car['first_position']), -1)])
    num_ids = len(landmarks)
    features_true = np.full((4, num_ids, len(t)), UNOBSERVED)
    features_true[:, obs_id, obs_frame] = z_true.T
    features = np.full_like(features_true, UNOBSERVED)
    features[:, obs_id, obs_frame] = z_meas.T
    outlier_mask = np.zeros((num_ids, len(t)), dtype=bool)
    outlier_mask[obs_id[is_outlier], obs_frame[is_outlier]] = True

    gyro_bias = _gyro_bias(rngs['gyro_bias'], opts['gyro_bias'])
    noise = rngs['twist_noise']
    linear_velocity = v_true + noise.normal(0.0, opts['velocity_noise'], v_true.shape)
    linear_velocity[:, at_rest] = 0.0
    rotational_velocity = (w_true + noise.normal(0.0, opts['gyro_noise'], w_true.shape)
                           + gyro_bias[:, None])

    result = {
        't': t, 'features': features, 'linear_velocity': linear_velocity,
        'rotational_velocity': rotational_velocity, 'K': KITTI_K.copy(), 'b': KITTI_BASELINE,
        'cam_T_imu': KITTI_CAM_T_IMU.copy(), 'image_size': np.array(KITTI_IMAGE_SIZE),
        'world_T_imu': world_T_imu, 'v_true': v_true, 'w_true': w_true,
        'features_true': features_true, 'outlier_mask': outlier_mask,
        'landmarks': landmarks, 'landmark_points': points, 'point_of_id': point_of_id,
        'gyro_bias': gyro_bias, 'path_length': path_length, 'options': opts,
    }
    if opts['accel_noise'] is not None:
        accel_bias = _three_values('accel_bias', opts['accel_bias'])
        true_force = specific_force(t, world_T_imu[:, :3, :3], v_true, up_world)
        result['specific_force'] = (true_force + accel_bias[:, None]
                                    + rngs['accel'].normal(0.0, opts['accel_noise'],
                                                           true_force.shape))
        result['up_world'] = up_world
        result['accel_bias'] = accel_bias
    return result


def _check_options(opts):
    positive = ('frames', 'rate_hz', 'speed_min', 'speed_max', 'max_yaw_rate',
                'landmark_density', 'target_obs', 'min_depth', 'max_depth')
    for name in positive:
        if not opts[name] > 0:
            raise ValueError('%s must be positive, got %r' % (name, opts[name]))
    if opts['length_m'] is not None and not opts['length_m'] > 0:
        raise ValueError('length_m must be positive, got %r' % opts['length_m'])
    for name in ('pixel_noise', 'velocity_noise', 'gyro_noise', 'time_jitter', 'min_disparity',
                 'roll_amplitude', 'pitch_amplitude', 'rest_pixel_jitter'):
        if not opts[name] >= 0:
            raise ValueError('%s must not be negative, got %r' % (name, opts[name]))
    for name in ('outlier_rate', 'track_loss', 'pixel_correlation'):
        if not 0 <= opts[name] < 1:
            raise ValueError('%s must be in [0, 1), got %r' % (name, opts[name]))
    if max(opts['roll_amplitude'], opts['pitch_amplitude']) > 30.0:
        raise ValueError('roll and pitch amplitudes must stay within 30 deg')
    if opts['speed_max'] - opts['speed_min'] < 1.0:
        raise ValueError('speed_max must exceed speed_min by at least 1 m/s')
    for stop in opts['stops']:
        if len(stop) != 2 or not (stop[0] >= STOP_RAMP_S and stop[1] > 0):
            raise ValueError('a stop is (start s >= %g, duration s > 0), got %r'
                             % (STOP_RAMP_S, stop))
    if not (float(opts['vehicles_ahead']).is_integer() and opts['vehicles_ahead'] >= 0):
        raise ValueError('vehicles_ahead must be a non-negative integer, got %r'
                         % opts['vehicles_ahead'])
    if not 0 <= opts['oncoming_per_minute'] < np.inf:
        raise ValueError('oncoming_per_minute must be finite and not negative, got %r'
                         % opts['oncoming_per_minute'])
    if opts['max_depth'] <= opts['min_depth']:
        raise ValueError('max_depth must exceed min_depth')
    if opts['time_jitter'] >= 0.25 / opts['rate_hz']:
        raise ValueError('time_jitter must be well below the frame interval')
    if not (float(opts['reuse_ids_after']).is_integer() and opts['reuse_ids_after'] >= 0):
        raise ValueError('reuse_ids_after must be a non-negative integer, got %r'
                         % opts['reuse_ids_after'])
    if opts['accel_noise'] is not None and not (0 <= opts['accel_noise'] < np.inf):
        raise ValueError('accel_noise must not be negative, got %r' % opts['accel_noise'])
    accel_bias = _three_values('accel_bias', opts['accel_bias'])
    if not np.all(np.isfinite(accel_bias)):
        raise ValueError('accel_bias must be finite, got %r' % opts['accel_bias'])
    if opts['accel_noise'] is None and np.any(accel_bias != 0.0):
        raise ValueError('accel_bias needs accel_noise (the accelerometer is off without it)')


# ---------------------------------------------------------------------------------------------
# Trajectory
# ---------------------------------------------------------------------------------------------
def _smooth_signal(rng, periods, count=3):
    """A smooth zero-mean function f(tau) in [-1, 1] (sum of sinusoids) and its derivative."""
    freq = 1.0 / rng.uniform(periods[0], periods[1], count)
    phase = rng.uniform(0.0, 2.0 * np.pi, count)
    amp = rng.uniform(0.5, 1.0, count)
    amp /= amp.sum()

    def value(tau):
        return np.sum(amp[:, None] * np.sin(2 * np.pi * freq[:, None] * tau + phase[:, None]), 0)

    def rate(tau):
        return np.sum(amp[:, None] * 2 * np.pi * freq[:, None]
                      * np.cos(2 * np.pi * freq[:, None] * tau + phase[:, None]), 0)
    return value, rate


def _yaw_rate_profile(rng, duration, max_yaw_rate):
    """Straight stretches with a slight road curvature, separated by smooth turns (sin^2 bumps
    of yaw rate, 20-100 deg each, peak yaw rate up to max_yaw_rate)."""
    turns = []
    tau = rng.uniform(3.0, 8.0)                       # start straight
    while tau < duration:
        peak = rng.uniform(0.4, 1.0) * max_yaw_rate * rng.choice([-1.0, 1.0])
        angle = np.radians(rng.uniform(20.0, 100.0))
        length = 2.0 * angle / abs(peak)
        turns.append((tau, length, peak))
        tau += length + rng.uniform(4.0, 12.0)        # straight stretch
    curvature, _ = _smooth_signal(rng, (20.0, 60.0))

    def yaw_rate(tau):
        rate = 0.01 * curvature(tau)
        for start, length, peak in turns:
            inside = (tau >= start) & (tau <= start + length)
            rate = rate + np.where(inside, peak * np.sin(np.pi * (tau - start) / length) ** 2, 0.0)
        return rate
    return yaw_rate


def travelled_distance(world_T_imu):
    """(T,) distance along the path from the first pose to each pose, m."""
    steps = np.linalg.norm(np.diff(world_T_imu[:, :3, 3], axis=0), axis=1)
    return np.concatenate([[0.0], np.cumsum(steps)])


def _frame_times(rng, num, opts):
    dt = 1.0 / opts['rate_hz'] + rng.uniform(-opts['time_jitter'], opts['time_jitter'], num - 1)
    return opts['start_time'] + np.concatenate([[0.0], np.cumsum(dt)])


def _drive(rng, opts):
    """Frame times, true body twists (3,T), world_T_imu (T,4,4) of a car-like drive, up_world
    (3,): the unit "up" (against gravity) in the world frame (the first pose), and at_rest (T,):
    the twist samples of a stop (`stops`) at which the vehicle stands still.

    Roll and pitch are against the level (ZYX Euler angles with the yaw): the first pose, the
    world frame, is level_R_imu0 = Ry(pitch0) Rx(roll0) (yaw 0) at tau = 0, so up_world =
    level_R_imu0^T e3.
    """
    dt = 1.0 / opts['rate_hz']
    if opts['length_m'] is not None:     # enough frames at the lowest speed, cut below
        num = int(math.ceil(opts['length_m'] / (opts['speed_min'] * dt))) + 2
    else:
        num = int(opts['frames'])
    t = _frame_times(rng, num, opts)
    duration = t[-1] - t[0]

    # Forward speed: monotone cubic through random knots every 6 s, inside the speed range.
    margin = 0.1 * (opts['speed_max'] - opts['speed_min'])
    knots = np.arange(-6.0, duration + 12.0, 6.0)
    speed = PchipInterpolator(knots, rng.uniform(opts['speed_min'] + margin,
                                                 opts['speed_max'] - margin, knots.size))
    yaw_rate = _yaw_rate_profile(rng, duration, opts['max_yaw_rate'])
    roll, roll_rate = _smooth_signal(rng, (8.0, 30.0))
    pitch, pitch_rate = _smooth_signal(rng, (10.0, 40.0))
    lateral, _ = _smooth_signal(rng, (5.0, 20.0))
    vertical, _ = _smooth_signal(rng, (3.0, 15.0))
    roll_amp, pitch_amp = np.radians(opts['roll_amplitude']), np.radians(opts['pitch_amplitude'])

    # Twist k+1 drives [t_k, t_k+1]: evaluate the profiles at the interval midpoints.
    tau = 0.5 * (t[:-1] + t[1:]) - t[0]
    phi, theta = roll_amp * roll(tau), pitch_amp * pitch(tau)
    moving = _moving_fraction(tau, opts['stops'])  # 1 on the road, 0 at rest
    dphi, dtheta, dpsi = (moving * roll_amp * roll_rate(tau), moving * pitch_amp * pitch_rate(tau),
                          moving * yaw_rate(tau))
    # Body angular velocity from ZYX Euler angle rates (keeps roll and pitch bounded).
    w = np.stack([dphi - dpsi * np.sin(theta),
                  dtheta * np.cos(phi) + dpsi * np.cos(theta) * np.sin(phi),
                  dpsi * np.cos(theta) * np.cos(phi) - dtheta * np.sin(phi)])
    v = moving * np.stack([speed(tau), 0.05 * lateral(tau), 0.03 * vertical(tau)])
    v_true = np.concatenate([v[:, :1], v], axis=1)
    w_true = np.concatenate([w[:, :1], w], axis=1)
    at_rest = np.concatenate([moving[:1], moving]) == 0.0
    roll0, pitch0 = roll_amp * roll(np.zeros(1))[0], pitch_amp * pitch(np.zeros(1))[0]
    up_world = level_up_in_body(roll0, pitch0)

    world_T_imu = np.empty((num, 4, 4))
    world_T_imu[0] = np.eye(4)
    for k in range(num - 1):
        world_T_imu[k + 1] = world_T_imu[k] @ se3.twist_exp(v_true[:, k + 1], w_true[:, k + 1],
                                                            t[k + 1] - t[k])

    if opts['length_m'] is not None:
        num = int(np.searchsorted(travelled_distance(world_T_imu), opts['length_m'])) + 1
        num = max(2, min(num, len(t)))
        t, v_true, w_true = t[:num], v_true[:, :num], w_true[:, :num]
        world_T_imu, at_rest = world_T_imu[:num], at_rest[:num]
    return t, v_true, w_true, world_T_imu, up_world, at_rest


def _moving_fraction(tau, stops):
    """(N,) factor of the drive's speed and rates at times tau (s from the start): 1 on the road,
    0 at rest during each (start, duration) stop, a half cosine over STOP_RAMP_S on either side."""
    fraction = np.ones_like(tau)
    for start, duration in stops:
        ramp_in = np.clip((start - tau) / STOP_RAMP_S, 0.0, 1.0)
        ramp_out = np.clip((tau - start - duration) / STOP_RAMP_S, 0.0, 1.0)
        level = np.maximum(ramp_in, ramp_out)  # 0 inside the stop, 1 beyond the ramps
        fraction *= 0.5 - 0.5 * np.cos(np.pi * level)
    return fraction


def level_up_in_body(roll, pitch):
    """The level frame's "up" (e3) in the axes of a body at this roll and pitch (rad, ZYX Euler
    angles against the level: level_R_body = Rz(yaw) Ry(pitch) Rx(roll), yaw irrelevant) -> (3,)
    = level_R_body^T e3."""
    return np.array([-math.sin(pitch), math.cos(pitch) * math.sin(roll),
                     math.cos(pitch) * math.cos(roll)])


def specific_force(t, world_R_imu, v_body, up_world, gravity=GRAVITY):
    """Noiseless accelerometer samples (3,T), m/s^2, body frame: sample k is the mean specific
    force over (t_k-1, t_k] expressed in the body frame at t_k,

        f_k = R_k^T (R_k v_k - R_k-1 v_k-1) / (t_k - t_k-1) + gravity R_k^T up_world,

    with R_k = world_R_imu[k] (T,3,3), v_k = v_body[:, k] (3,T) the body linear velocity of twist
    k (the one that drives [t_k-1, t_k]) and up_world the unit "up" (against gravity) in world
    axes. Sample 0 repeats sample 1 (a single frame: the gravity term alone). At rest and level
    f = (0, 0, +gravity).
    """
    t = np.asarray(t, dtype=float)
    R = np.asarray(world_R_imu, dtype=float)
    velocity_world = np.einsum('kij,jk->ki', R, v_body)                 # (T,3): R_k v_k
    up_body = np.einsum('kji,j->ki', R, np.asarray(up_world, dtype=float))  # (T,3): R_k^T up
    force = gravity * up_body
    if t.size > 1:
        change = np.diff(velocity_world, axis=0) / np.diff(t)[:, None]
        force[1:] += np.einsum('kji,kj->ki', R[1:], change)
        force[0] = force[1]
    return force.T


# ---------------------------------------------------------------------------------------------
# Scene
# ---------------------------------------------------------------------------------------------
def _extended_path(world_T_imu, opts):
    """The drive's path, extended straight beyond both ends by max_depth + 10 m so that the first
    and last frames see a scene too -> (positions (N,3), horizontal unit heading (N,3), distance
    along the path (N,), negative before the first pose)."""
    positions = world_T_imu[:, :3, 3]
    heading = world_T_imu[:, :3, 0].copy()
    heading[:, 2] = 0.0
    heading /= np.linalg.norm(heading, axis=1, keepdims=True)
    arc = travelled_distance(world_T_imu)
    steps = np.arange(1.0, opts['max_depth'] + 11.0)
    before = positions[0] - steps[::-1, None] * heading[0]
    after = positions[-1] + steps[:, None] * heading[-1]
    path = np.concatenate([before, positions, after])
    path_heading = np.concatenate([np.repeat(heading[:1], steps.size, 0), heading,
                                   np.repeat(heading[-1:], steps.size, 0)])
    return path, path_heading, np.concatenate([-steps[::-1], arc, arc[-1] + steps])


def _landmark_points(rng, world_T_imu, opts):
    """Points on both sides of the road: lateral 3-25 m, height -1.5..6 m relative to the IMU,
    uniformly along the path (and max_depth beyond its ends); none within 3 m of the road."""
    path, path_heading, path_arc = _extended_path(world_T_imu, opts)
    count = int(round(opts['landmark_density'] * (path_arc[-1] - path_arc[0])))
    s = rng.uniform(path_arc[0], path_arc[-1], count)
    side = rng.choice([-1.0, 1.0], count)
    lateral = rng.uniform(3.0, 25.0, count)
    height = rng.uniform(-1.5, 6.0, count)
    base = np.stack([np.interp(s, path_arc, path[:, i]) for i in range(3)], axis=1)
    direction = np.stack([np.interp(s, path_arc, path_heading[:, i]) for i in range(2)], axis=1)
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    left = np.stack([-direction[:, 1], direction[:, 0]], axis=1)
    points = base.copy()
    points[:, :2] += (side * lateral)[:, None] * left
    points[:, 2] += height

    # Inside a turn a point can land on another part of the road: drop those.
    dense = np.concatenate([np.linspace(path[i], path[i + 1], 5, endpoint=False)
                            for i in range(len(path) - 1)] + [path[-1:]])
    distance, _ = cKDTree(dense[:, :2]).query(points[:, :2])
    return points[distance >= 3.0]


def project(points_world, world_T_imu, cam_T_imu=KITTI_CAM_T_IMU, K=KITTI_K, b=KITTI_BASELINE):
    """Stereo projection of world points (N,3) at pose world_T_imu -> (z (N,4), depth (N,))."""
    cam_T_world = cam_T_imu @ se3.inverse(world_T_imu)
    return stereo_geometry.project(points_world @ cam_T_world[:3, :3].T + cam_T_world[:3, 3], K, b)


def _visible(z, depth, opts):
    width, height = KITTI_IMAGE_SIZE
    return ((depth >= opts['min_depth']) & (depth <= opts['max_depth'])
            & (z[:, 0] - z[:, 2] > opts['min_disparity'])
            & (z[:, 0] >= 0) & (z[:, 0] <= width - 1) & (z[:, 2] >= 0) & (z[:, 2] <= width - 1)
            & (z[:, 1] >= 0) & (z[:, 1] <= height - 1))


def _visibility_radius(opts):
    """Distance from the IMU beyond which no point is visible (depth <= max_depth inside the image,
    plus the camera's offset from the IMU): only points within it need projecting."""
    width, height = KITTI_IMAGE_SIZE
    fx, fy, cx, cy = KITTI_K[0, 0], KITTI_K[1, 1], KITTI_K[0, 2], KITTI_K[1, 2]
    x_max = max(cx, width - 1 - cx) / fx
    y_max = max(cy, height - 1 - cy) / fy
    offset = np.linalg.norm(se3.inverse(KITTI_CAM_T_IMU)[:3, 3])
    return opts['max_depth'] * math.sqrt(1.0 + x_max ** 2 + y_max ** 2) + offset + 1.0


def _track(rng, points, world_T_imu, opts):
    """Feature tracks over the frames -> (frame, point, id, z_true (n,4)) per observation.

    A track continues while its point stays observable, except for a small per-frame loss; new
    tracks start on observable untracked points (a new id every time, or with reuse_ids_after the
    smallest id unseen for that many frames) up to a per-frame target that varies smoothly around
    target_obs. Each track is thus one contiguous run of an id.
    """
    num = len(world_T_imu)
    wobble, _ = _smooth_signal(rng, (100.0, 400.0))
    target = np.maximum(1, np.round(opts['target_obs'] * (1.0 + 0.25 * wobble(np.arange(num)))))
    max_new = max(1, min(10, int(opts['target_obs'])), int(opts['target_obs']) // 2)
    reuse_after = int(opts['reuse_ids_after'])
    free_ids, ended_ids = [], collections.deque()  # heap of reusable ids; (frame, id) pending
    # Only the points near the pose can be visible: project those (same result as all points).
    tree = cKDTree(points)
    radius = _visibility_radius(opts)
    visible = np.zeros(len(points), dtype=bool)
    was_active = np.zeros(len(points), dtype=bool)
    z = np.zeros((len(points), 4))
    active_points = np.zeros(0, dtype=np.int64)
    active_ids = np.zeros(0, dtype=np.int64)
    next_id = 0
    frames, pts, ids, zs = [], [], [], []
    for k in range(num):
        near = np.sort(np.asarray(tree.query_ball_point(world_T_imu[k][:3, 3], radius),
                                  dtype=np.int64))
        z_near, depth_near = project(points[near], world_T_imu[k])
        seen = near[_visible(z_near, depth_near, opts)]
        visible[seen] = True
        z[near] = z_near
        previous = active_points
        was_active[previous] = True
        keep = visible[active_points] & (rng.random(active_points.size) >= opts['track_loss'])
        if reuse_after:
            ended_ids.extend((k, i) for i in active_ids[~keep])
        active_points, active_ids = active_points[keep], active_ids[keep]
        wanted = int(target[k]) - active_points.size
        if k > 0:
            wanted = min(wanted, max_new)
        candidates = seen[~was_active[seen]]
        new = min(max(wanted, 0), candidates.size)
        if new:
            started = rng.choice(candidates, new, replace=False)
            while ended_ids and ended_ids[0][0] + reuse_after <= k:
                heapq.heappush(free_ids, ended_ids.popleft()[1])
            reused = [heapq.heappop(free_ids) for _ in range(min(new, len(free_ids)))]
            fresh = np.arange(next_id, next_id + new - len(reused))
            next_id += fresh.size
            active_points = np.concatenate([active_points, started])
            active_ids = np.concatenate([active_ids, np.array(reused, dtype=np.int64), fresh])
        frames.append(np.full(active_points.size, k))
        pts.append(active_points)
        ids.append(active_ids)
        zs.append(z[active_points])
        visible[seen] = False
        was_active[previous] = False
    return (np.concatenate(frames), np.concatenate(pts), np.concatenate(ids),
            np.concatenate(zs))


def _vehicle_observations(rng, noise_rng, t, world_T_imu, opts):
    """The tracks on the other cars (traffic.vehicle_tracks), measured as the scene's are (their
    own noise stream, so the scene's measurements stay those of the drive without traffic) ->
    dict of frame, id (from 0), z_true, z, is_outlier, first_position (per id)."""
    def observe(points_world, pose):
        z, depth = project(points_world, pose)
        return z, _visible(z, depth, opts)

    frame, ids, z_true, first = traffic.vehicle_tracks(
        rng, t, world_T_imu, travelled_distance(world_T_imu), _extended_path(world_T_imu, opts),
        (KITTI_CAM_T_IMU, observe), opts)
    z, is_outlier = _measure_pixels(noise_rng, z_true, frame, ids, opts)
    return {'frame': frame, 'id': ids, 'z_true': z_true, 'z': z, 'is_outlier': is_outlier,
            'first_position': first}


# ---------------------------------------------------------------------------------------------
# Measurements
# ---------------------------------------------------------------------------------------------
def _pixel_errors(rng, obs_frame, obs_id, opts, still=None):
    """Pixel error of every observation (n,4): white, or AR(1) along each track (a track: an id
    seen in consecutive frames), e_k = rho e_(k-1) + sqrt(1 - rho^2) sigma n_k, e_0 = sigma n_0.
    At a frame whose pose is the one before (`still`, per frame), a track seen there too keeps
    that frame's error plus rest_pixel_jitter."""
    errors = rng.normal(0.0, opts['pixel_noise'], (obs_id.size, 4))
    rho = opts['pixel_correlation']
    stops = still is not None and bool(np.any(still))
    if (rho == 0.0 and not stops) or obs_id.size == 0:
        return errors
    jitter = rng.normal(0.0, opts['rest_pixel_jitter'], errors.shape) if stops else None
    scale = np.sqrt(1.0 - rho * rho)
    last_frame = np.full(int(obs_id.max()) + 1, -2, dtype=np.int64)
    last_error = np.zeros((last_frame.size, 4))
    for k in np.unique(obs_frame):  # observations are in frame order
        idx = np.flatnonzero(obs_frame == k)
        ids = obs_id[idx]
        going_on = idx[last_frame[ids] == k - 1]
        if stops and still[k]:
            errors[going_on] = last_error[obs_id[going_on]] + jitter[going_on]
        elif rho > 0.0:
            errors[going_on] = rho * last_error[obs_id[going_on]] + scale * errors[going_on]
        last_error[ids] = errors[idx]
        last_frame[ids] = k
    return errors


def _track_drift(z_true, obs_frame, obs_id, opts):
    """Systematic drift of every observation (n,4): after `age` frames of its track, u_left and
    u_right move by age drift_expansion x (x: the point's normalized image coordinate in that
    camera) and both rows by age drift_v. Zero when both options are 0."""
    drift = np.zeros((obs_id.size, 4))
    if (opts['drift_expansion'] == 0.0 and opts['drift_v'] == 0.0) or obs_id.size == 0:
        return drift
    first_frame = np.full(int(obs_id.max()) + 1, np.iinfo(np.int64).max, dtype=np.int64)
    np.minimum.at(first_frame, obs_id, obs_frame)
    age = (obs_frame - first_frame[obs_id]).astype(float)
    fx, cx = KITTI_K[0, 0], KITTI_K[0, 2]
    for col in (0, 2):
        drift[:, col] = age * opts['drift_expansion'] * (z_true[:, col] - cx) / fx
    drift[:, 1] = drift[:, 3] = age * opts['drift_v']
    return drift


def _measure_pixels(rng, z_true, obs_frame, obs_id, opts, still=None):
    """Pixel noise on every coordinate, and gross outliers -> (z (n,4), is_outlier (n,)).

    An outlier (probability outlier_rate) is a wrong match: a third get a negative disparity
    (u_right 2-60 px right of u_left), the others random 20-200 px offsets on some coordinates;
    outliers stay inside the image.
    """
    width, height = KITTI_IMAGE_SIZE
    limits = np.array([width - 1, height - 1, width - 1, height - 1], float)
    n = z_true.shape[0]
    z = (z_true + _pixel_errors(rng, obs_frame, obs_id, opts, still)
         + _track_drift(z_true, obs_frame, obs_id, opts))
    z[:, 2] -= opts['disparity_offset']
    is_outlier = rng.random(n) < opts['outlier_rate']
    idx = np.flatnonzero(is_outlier)
    negative = rng.random(idx.size) < 1.0 / 3.0

    # Offsets of 20-200 px on a random non-empty subset of the four coordinates; flip the sign
    # when that leaves the image, clip as a last resort.
    shifted = idx[~negative]
    pick = rng.random((shifted.size, 4)) < 0.5
    pick[np.arange(shifted.size), rng.integers(0, 4, shifted.size)] = True
    offset = (rng.uniform(20.0, 200.0, (shifted.size, 4))
              * rng.choice([-1.0, 1.0], (shifted.size, 4)))
    base = z[shifted]
    moved = base + offset
    outside = (moved < 0) | (moved > limits)
    moved = np.where(outside, base - offset, moved)
    z[shifted] = np.where(pick, np.clip(moved, 0.0, limits), base)

    # Negative disparity: the right image point lies to the right of the left one.
    flipped = idx[negative]
    gap = rng.uniform(2.0, 60.0, flipped.size)
    u_left, u_right = z[flipped, 0], z[flipped, 2]
    fits = u_left + gap <= width - 1
    z[flipped, 2] = np.where(fits, u_left + gap, u_right)
    z[flipped, 0] = np.where(fits, u_left, u_right - gap)
    return z, is_outlier


def _gyro_bias(rng, option):
    """Constant gyro offset (3,): from the option (scalar or 3 values), else each axis drawn
    uniformly from +-[0.005, 0.01] rad/s."""
    drawn = rng.uniform(0.005, 0.01, 3) * rng.choice([-1.0, 1.0], 3)
    if option is None:
        return drawn
    return _three_values('gyro_bias', option)


def _three_values(name, option):
    """An option of one value (all three axes) or three -> (3,) float."""
    values = np.asarray(option, dtype=float).reshape(-1)
    if values.size == 1:
        return np.repeat(values, 3)
    if values.size != 3:
        raise ValueError('%s: give one value or three, got %d' % (name, values.size))
    return values


# ---------------------------------------------------------------------------------------------
# Output
# ---------------------------------------------------------------------------------------------
def dataset_arrays(result):
    """The npz content (2019 course layout + our marker and image size, and the accelerometer's
    specific_force when the simulation has one) of a simulation."""
    arrays = {
        'time_stamps': result['t'][None, :],
        'features': result['features'],
        'linear_velocity': result['linear_velocity'],
        'rotational_velocity': result['rotational_velocity'],
        'K': result['K'],
        'b': np.array(result['b']),
        'cam_T_imu': result['cam_T_imu'],
        TRANSLATION_CORRECT_KEY: np.array(True),
        'image_size': np.asarray(result['image_size'], dtype=np.int64),
    }
    if 'specific_force' in result:  # only with the accelerometer on
        arrays['specific_force'] = result['specific_force']
    return arrays


def output_paths(prefix):
    return {'npz': prefix + '.npz', 'groundtruth': prefix + '_groundtruth.tum',
            'landmarks': prefix + '_landmarks.csv'}


def write_outputs(result, prefix):
    """Write PREFIX.npz, PREFIX_groundtruth.tum, PREFIX_landmarks.csv -> dict of the paths."""
    paths = output_paths(prefix)
    np.savez_compressed(paths['npz'], **dataset_arrays(result))
    trajectory.write_tum(paths['groundtruth'], result['t'], result['world_T_imu'])
    with open(paths['landmarks'], 'w') as f:
        f.write('id,x,y,z\n')
        for j, (x, y, z) in enumerate(result['landmarks']):
            f.write('%d,%.9f,%.9f,%.9f\n' % (j, x, y, z))
    return paths


def statistics(features):
    """Observation statistics of a (4,M,T) features array -> dict: obs_per_frame (T,),
    track_lengths (M,) (observations per id), contiguous (every id seen in one run of frames),
    track_starts (number of runs: tracks)."""
    observed = observed_mask(features)
    track_lengths = observed.sum(axis=1)
    starts = np.diff(observed.astype(np.int8), axis=1, prepend=0) == 1
    return {'obs_per_frame': observed.sum(axis=0), 'track_lengths': track_lengths,
            'contiguous': bool(np.all(starts.sum(axis=1) <= 1)),
            'track_starts': int(starts.sum())}


def summary(result):
    """One line: frames, path length, ids, mean observations per frame, mean track length, gyro
    offset (and the accelerometer's noise and offset when it has one)."""
    stats = statistics(result['features'])
    tracks = max(1, int(stats['track_starts']))  # = ids unless reuse_ids_after
    text = ('%d frames, %.0f m, %d feature ids, %.1f observations/frame (min %d), '
            'mean track %.1f frames, gyro offset (%.4f, %.4f, %.4f) rad/s'
            % (len(result['t']), result['path_length'], result['features'].shape[1],
               stats['obs_per_frame'].mean(), stats['obs_per_frame'].min(),
               stats['obs_per_frame'].sum() / tracks, *result['gyro_bias']))
    if 'specific_force' in result:
        text += (', accelerometer noise %g m/s^2, offset (%.4f, %.4f, %.4f) m/s^2'
                 % (result['options']['accel_noise'], *result['accel_bias']))
    return text
