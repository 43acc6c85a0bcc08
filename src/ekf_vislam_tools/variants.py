"""Regime variants of a course dataset: another twist (the file's own, or one computed from the
ground truth with chosen noise) and a seeded subset of the landmark ids. The npz keeps its layout
and every other key."""
import numpy as np

from ekf_vislam_tools import se3, trajectory

TIME_KEYS = ('time_stamps', 't')
ANGULAR_KEYS = ('rotational_velocity', 'angular_velocity')


class VariantError(ValueError):
    """A dataset or ground truth that cannot make a variant; the message says why."""


def _key(data, names):
    for name in names:
        if name in data:
            return name
    raise VariantError('none of %s in the dataset' % ', '.join(names))


def groundtruth_twist(t_frames, t_gt, world_T_imu_gt, max_dt=0.02):
    """Body twist [v; w] (3,T) of the IMU from ground-truth poses: sample k drives
    [t_k-1, t_k] (T(k) = T(k-1) exp(tau [w^ v; 0 0])); sample 0 repeats sample 1.
    Every frame needs a ground-truth pose within max_dt."""
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
    v = np.zeros((3, len(t_frames)))
    w = np.zeros((3, len(t_frames)))
    for k in range(1, len(t_frames)):
        tau = t_frames[k] - t_frames[k - 1]
        xi = se3.se3_log(se3.inverse(poses[k - 1]) @ poses[k]) / tau
        v[:, k], w[:, k] = xi[:3], xi[3:]
    if len(t_frames) > 1:
        v[:, 0], w[:, 0] = v[:, 1], w[:, 1]
    return v, w


def make_variant(data, groundtruth_path, twist='course', twist_noise=(0.05, 0.005),
                 gyro_offset=0.001, keep_fraction=1.0, seed=0):
    """-> (dict of arrays, notes). `data` is a dict of the npz's arrays. Frames after the last
    ground-truth pose are cut off (every key indexed by frame)."""
    out = {key: np.array(value) for key, value in data.items()}
    time_key = _key(out, TIME_KEYS)
    angular_key = _key(out, ANGULAR_KEYS)
    t = np.asarray(out[time_key], dtype=float).ravel()
    t_gt, world_T_imu_gt = trajectory.read_tum(groundtruth_path)
    order = np.argsort(t_gt)
    t_gt, world_T_imu_gt = t_gt[order], world_T_imu_gt[order]
    notes = []
    last = int(np.searchsorted(t, t_gt[-1] + 0.02, side='right'))
    if last < 2:
        raise VariantError('the ground truth covers fewer than 2 frames')
    if last < t.size:
        notes.append('cut to the %d frames with ground truth (of %d)' % (last, t.size))
        num = t.size
        for key, value in out.items():
            if value.ndim >= 1 and value.shape[-1] == num and key not in ('K', 'cam_T_imu',
                                                                            'imu_T_cam'):
                out[key] = value[..., :last]
        t = t[:last]
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
    if not 0.0 < keep_fraction <= 1.0:
        raise VariantError('keep fraction must be in (0, 1]')
    if keep_fraction < 1.0:
        features = out['features']
        ids = features.shape[1]
        kept = np.zeros(ids, dtype=bool)
        kept[rng.choice(ids, size=max(1, int(round(keep_fraction * ids))), replace=False)] = True
        features[:, ~kept, :] = -1
        notes.append('kept %d of %d ids' % (kept.sum(), ids))
    return out, notes
