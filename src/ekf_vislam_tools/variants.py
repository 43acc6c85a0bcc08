"""Regime variants of a course dataset: another twist (the file's own, or one computed from the
ground truth with chosen noise), optionally an accelerometer computed from the ground truth
(``specific_force``, see `groundtruth_specific_force`), a seeded subset of the landmark ids, and
the course files' repeated frames taken out (`split_at_repeated_frames`). The npz keeps its
layout and every other key."""
import numpy as np

from ekf_vislam_tools import se3, simulator, trajectory

TIME_KEYS = ('time_stamps', 't')
ANGULAR_KEYS = ('rotational_velocity', 'angular_velocity')


class VariantError(ValueError):
    """A dataset or ground truth that cannot make a variant; the message says why."""


def _key(data, names):
    for name in names:
        if name in data:
            return name
    raise VariantError('none of %s in the dataset' % ', '.join(names))


def repeated_frames(features, min_shared=5):
    """Frames that re-publish the previous one, by the estimator's rule (RepeatedFrameDetector):
    at least `min_shared` tracks observed in both, and more than half of them with the same four
    coordinates. -> bool array, one per frame."""
    observed = features[0] != -1
    repeated = np.zeros(features.shape[2], dtype=bool)
    for k in range(1, features.shape[2]):
        shared = observed[:, k] & observed[:, k - 1]
        count = int(shared.sum())
        if count < min_shared:
            continue
        same = np.all(features[:, shared, k] == features[:, shared, k - 1], axis=0)
        repeated[k] = 2 * int(same.sum()) > count
    return repeated


def split_at_repeated_frames(features):
    """-> (features, repeated frames, tracks split). Each repeated frame is emptied, and a track
    observed both before and after one goes on under a new id (a column appended) after it: the
    course files' tracks are one image period off their stamps after such a frame, which the
    estimator's repeated-frame handling needs the repeat itself to know. Without them a variant
    may drop frames (a slower camera, dataset_to_bag.py --features-every) and keep no stale copy
    of a dropped frame."""
    features = np.array(features)
    repeated = repeated_frames(features)
    features[:, :, repeated] = -1
    cuts = np.flatnonzero(repeated)
    observed = features[0] != -1
    appended = []
    for column in range(features.shape[1]):
        frames = np.flatnonzero(observed[column])
        segment = np.searchsorted(cuts, frames)  # how many repeated frames lie before each
        for later in np.unique(segment)[1:]:
            moved = frames[segment == later]
            new = np.full((features.shape[0], features.shape[2]), -1, dtype=features.dtype)
            new[:, moved] = features[:, column, moved]
            features[:, column, moved] = -1
            appended.append(new)
    if appended:
        features = np.concatenate([features, np.stack(appended, axis=1)], axis=1)
    return features, int(repeated.sum()), len(appended)


def groundtruth_poses(t_frames, t_gt, world_T_imu_gt, max_dt=0.02):
    """The ground-truth pose of each frame (the nearest in time) -> list of (4,4) world_T_imu.
    Every frame needs a ground-truth pose within max_dt (else VariantError)."""
    t_gt = np.asarray(t_gt, dtype=float)
    idx = np.searchsorted(t_gt, t_frames)
    poses = []
    for k, t in enumerate(t_frames):
        candidates = [i for i in (idx[k] - 1, idx[k]) if 0 <= i < t_gt.size]
        best = min(candidates, key=lambda i: abs(t_gt[i] - t))
        if abs(t_gt[best] - t) > max_dt:
            raise VariantError('frame %d (t = %.6f) has no ground-truth pose within %g s'
                               % (k, t, max_dt))
        poses.append(world_T_imu_gt[best])
    return poses


def groundtruth_twist(t_frames, t_gt, world_T_imu_gt, max_dt=0.02):
    """Body twist [v; w] (3,T) of the IMU from ground-truth poses: sample k drives
    [t_k-1, t_k] (T(k) = T(k-1) exp(tau [w^ v; 0 0])); sample 0 repeats sample 1.
    Every frame needs a ground-truth pose within max_dt."""
    poses = groundtruth_poses(t_frames, t_gt, world_T_imu_gt, max_dt)
    v = np.zeros((3, len(t_frames)))
    w = np.zeros((3, len(t_frames)))
    for k in range(1, len(t_frames)):
        tau = t_frames[k] - t_frames[k - 1]
        xi = se3.se3_log(se3.inverse(poses[k - 1]) @ poses[k]) / tau
        v[:, k], w[:, k] = xi[:3], xi[3:]
    if len(t_frames) > 1:
        v[:, 0], w[:, 0] = v[:, 1], w[:, 1]
    return v, w


def mean_up_axis(world_T_imu):
    """Stand-in for gravity's "up" in a world frame that is not level (the ground truth's world
    is the first camera frame): the normalized mean of the IMU's z axis (up in the body) in world
    axes over the poses (N,4,4) of a drive -> (3,). Over a long drive the vehicle's roll and pitch
    average out to about zero, so this is about the level's up (off by the mean tilt: a road that
    climbs or leans on average tilts it)."""
    z_axes = np.asarray(world_T_imu)[:, :3, 2]
    mean = z_axes.mean(axis=0)
    norm = np.linalg.norm(mean)
    if not norm > 0:
        raise VariantError('the IMU z axes of the ground truth average out to zero: no up')
    return mean / norm


def groundtruth_specific_force(t_frames, t_gt, world_T_imu_gt, up_world=None, max_dt=0.02):
    """Noiseless accelerometer samples (3,T), m/s^2, IMU frame, from the ground truth ->
    (specific_force, up_world): sample k is the mean specific force over (t_k-1, t_k] in the body
    frame at t_k (`simulator.specific_force`), from the ground-truth poses at the frame stamps
    (the nearest within max_dt, as `groundtruth_twist`) and the ground-truth body linear
    velocities of the accurate twist (sample k drives [t_k-1, t_k]). up_world: the unit "up"
    (against gravity) in the ground truth's world axes; None: `mean_up_axis` of those poses (the
    average IMU z axis over the drive, our stand-in for gravity's direction)."""
    poses = np.array(groundtruth_poses(t_frames, t_gt, world_T_imu_gt, max_dt))
    v, _ = groundtruth_twist(t_frames, t_gt, world_T_imu_gt, max_dt)
    if up_world is None:
        up_world = mean_up_axis(poses)
    else:
        up_world = np.asarray(up_world, dtype=float).reshape(3)
        up_world = up_world / np.linalg.norm(up_world)
    return simulator.specific_force(t_frames, poses[:, :3, :3], v, up_world), up_world


def _accel_rng(seed):
    """The accelerometer noise's own stream from the variant's seed (independent of the
    generator of the twist noise and the id subset, so these stay as they are without it)."""
    return np.random.default_rng(np.random.SeedSequence(seed).spawn(1)[0])


def frames_with_groundtruth(t_frames, t_gt, max_dt=0.02):
    """How many of the frames (stamps t_frames, increasing) come before the ground truth ends (its
    last stamp plus max_dt): the frames a variant keeps."""
    return int(np.searchsorted(t_frames, np.max(t_gt) + max_dt, side='right'))


def _slice_frames(out, t, start, stop):
    """Keeps frames [start, stop) of every key indexed by frame (the last axis as long as the
    time stamps; not the calibration) in `out`, in place -> the kept time stamps."""
    for key, value in out.items():
        if value.ndim >= 1 and value.shape[-1] == t.size and key not in ('K', 'cam_T_imu',
                                                                          'imu_T_cam'):
            out[key] = value[..., start:stop]
    return t[start:stop]


def make_variant(data, groundtruth_path, twist='course', twist_noise=(0.05, 0.005),
                 gyro_offset=0.001, keep_fraction=1.0, seed=0, accel_noise=None, accel_bias=0.0,
                 up_world=None, cam_T_imu=None, split_repeated=False, speed_scale=1.0,
                 frames=None):
    """-> (dict of arrays, notes). `data` is a dict of the npz's arrays. Frames after the last
    ground-truth pose are cut off (every key indexed by frame). The ground truth is a TUM file of
    world_T_imu or, with the dataset's cam_T_imu (translation corrected), a KITTI poses file.

    accel_noise (m/s^2, per component and sample; None: no accelerometer, the npz's own
    specific_force, if any, is kept) writes ``specific_force`` (3,T) from the ground truth
    (`groundtruth_specific_force`, with either twist) plus white noise and a constant offset
    accel_bias (m/s^2, one value or three, body axes). Its noise has its own stream from the
    seed. up_world: gravity's "up" in the ground truth's world axes (default: the mean IMU z axis
    over the drive, a stand-in, since the ground truth's world is not level). split_repeated:
    `split_at_repeated_frames`, before the id subset. speed_scale multiplies the twist's linear
    velocity (either twist, noise included): a wheel odometry with a wrong wheel radius.
    frames = (first, count) keeps that section of the frames (a drive started elsewhere: at
    speed, on a slope, in a turn) before anything else is made; its stamps stay those of the
    file, so the ground truth needs no change (evaluate.py and the NEES take the section's
    first pose as the estimator's world)."""
    out = {key: np.array(value) for key, value in data.items()}
    time_key = _key(out, TIME_KEYS)
    angular_key = _key(out, ANGULAR_KEYS)
    t = np.asarray(out[time_key], dtype=float).ravel()
    t_gt, world_T_imu_gt = trajectory.read_groundtruth(groundtruth_path, t, cam_T_imu)
    order = np.argsort(t_gt)
    t_gt, world_T_imu_gt = t_gt[order], world_T_imu_gt[order]
    notes = []
    last = frames_with_groundtruth(t, t_gt)
    if last < 2:
        raise VariantError('the ground truth covers fewer than 2 frames')
    if last < t.size:
        notes.append('cut to the %d frames with ground truth (of %d)' % (last, t.size))
        t = _slice_frames(out, t, 0, last)
    if frames is not None:
        first, count = (int(x) for x in frames)
        if not (0 <= first and count >= 2 and first + count <= t.size):
            raise VariantError('frames %d-%d: the dataset (with ground truth) has frames 0-%d, '
                               'and a section needs 2 or more' % (first, first + count - 1,
                                                                  t.size - 1))
        notes.append('frames %d-%d of %d (%.1f s from %.1f s)'
                     % (first, first + count - 1, t.size, t[first + count - 1] - t[first],
                        t[first] - t[0]))
        t = _slice_frames(out, t, first, first + count)
    rng = np.random.default_rng(seed)
    if twist == 'accurate':
        v, w = groundtruth_twist(t, t_gt, world_T_imu_gt)
        v = v + rng.normal(0.0, twist_noise[0], v.shape)
        w = w + rng.normal(0.0, twist_noise[1], w.shape) + gyro_offset
        out['linear_velocity'] = v.astype(out['linear_velocity'].dtype)
        out[angular_key] = w.astype(out[angular_key].dtype)
        notes.append('twist from the ground truth + white noise %g m/s, %g rad/s per sample, '
                     'gyro offset %g rad/s' % (twist_noise[0], twist_noise[1], gyro_offset))
    elif twist != 'course':
        raise VariantError('twist must be course or accurate, not %r' % twist)
    if not 0.0 < speed_scale < np.inf:
        raise VariantError('the speed scale must be positive and finite')
    if speed_scale != 1.0:
        out['linear_velocity'] = (speed_scale * out['linear_velocity']).astype(
            out['linear_velocity'].dtype)
        notes.append('linear velocity x %g' % speed_scale)
    if accel_noise is not None:
        if not 0.0 <= accel_noise < np.inf:
            raise VariantError('accelerometer noise must not be negative')
        bias = np.asarray(accel_bias, dtype=float).reshape(-1)
        if bias.size not in (1, 3) or not np.all(np.isfinite(bias)):
            raise VariantError('accelerometer offset: give one finite value or three')
        force, up = groundtruth_specific_force(t, t_gt, world_T_imu_gt, up_world)
        force = (force + np.broadcast_to(bias, 3)[:, None]
                 + _accel_rng(seed).normal(0.0, accel_noise, force.shape))
        out['specific_force'] = force
        notes.append('specific force from the ground truth (up = (%.4f, %.4f, %.4f) in its '
                     'world) + white noise %g m/s^2 per sample, offset %s m/s^2'
                     % (up[0], up[1], up[2], accel_noise,
                        ', '.join('%g' % x for x in bias)))
    elif np.any(np.asarray(accel_bias) != 0.0) or up_world is not None:
        raise VariantError('an accelerometer offset or up needs the accelerometer noise')
    if not 0.0 < keep_fraction <= 1.0:
        raise VariantError('keep fraction must be in (0, 1]')
    if split_repeated:
        out['features'], repeats, split = split_at_repeated_frames(out['features'])
        notes.append('%d repeated frames emptied, %d tracks through them split (new ids)'
                     % (repeats, split))
    if keep_fraction < 1.0:
        features = out['features']
        ids = features.shape[1]
        kept = np.zeros(ids, dtype=bool)
        kept[rng.choice(ids, size=max(1, int(round(keep_fraction * ids))), replace=False)] = True
        features[:, ~kept, :] = -1
        notes.append('kept %d of %d ids' % (kept.sum(), ids))
    return out, notes
