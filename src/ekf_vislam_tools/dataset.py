"""Loading and validation of course datasets (npz files) into one checked `Dataset`.

Two layouts exist (see the data README):

- 2019 course files: ``time_stamps`` (1,T), ``features`` (4,M,T), ``linear_velocity`` (3,T),
  ``rotational_velocity`` (3,T), ``K`` (3x3), ``b`` (scalar), ``cam_T_imu`` (4x4). The stored
  ``cam_T_imu`` translation is wrong (it holds the translation of imu_T_cam); the correct one is
  ``-R @ t``. Files written by our simulator carry ``cam_T_imu_translation_correct = True`` and are
  left alone.
- later course files: ``t`` or ``time_stamps``, ``angular_velocity`` instead of
  ``rotational_velocity`` and ``imu_T_cam`` instead of ``cam_T_imu`` (inverted, never "fixed").

Optional extra keys: ``feature_columns_shared`` (a column may hold several tracks, one after the
other; written by track_stereo_images for long sequences); ``image_size`` = [width, height];
``specific_force`` (3,T): the accelerometer, m/s^2, IMU frame (x forward, y left, z up), sample k
the mean specific force over (t_k-1, t_k] expressed in the body frame at t_k, gravity included
(at rest and level (0, 0, +9.80665)).

The twist and the extrinsic must use the same IMU axes. A file whose twist turns the other way
than its images (its y and z axes against the extrinsic's: a half turn about x, as in the
KITTI-360 course file) is found by `twist_axes.check` and its twist turned into the extrinsic's
axes (`Dataset.twist_axes_turned`). The specific force is not turned with it: our tools compute it
from ground-truth poses in the extrinsic's IMU axes (simulator, make_variant.py).

Every problem is reported as a `DatasetError` whose message starts with the file name and names the
field, e.g. ``data.npz: field 'linear_velocity': non-finite value at frame 17``. Files are read
with ``allow_pickle=False``: object arrays are refused, never unpickled.
"""
import collections
import zipfile
import zlib

import numpy as np

from ekf_vislam_tools import se3, twist_axes

#: Marker key written by our simulator: the stored cam_T_imu translation is already correct.
TRANSLATION_CORRECT_KEY = 'cam_T_imu_translation_correct'
#: Marker key written by track_stereo_images (--reuse-gap): a column of features may hold several
#: tracks, one after the other, each run of consecutive frames a track of its own.
COLUMNS_SHARED_KEY = 'feature_columns_shared'

#: Value of all four coordinates of an unobserved feature.
UNOBSERVED = -1.0

LAYOUT_2019 = '2019'
LAYOUT_LATER = 'later'

_ORTHONORMAL_TOL = 1e-3

_DATASET_FIELDS = [
    'path',             # str: the file as given
    'layout',           # LAYOUT_2019 or LAYOUT_LATER
    't',                # (T,) float64 time stamps, s, strictly increasing
    'features',         # (4, M, T) float64 [uL, vL, uR, vR]; all four -1 where unobserved
    'v',                # (3, T) float64 body-frame linear velocity of the IMU, m/s
    'w',                # (3, T) float64 body-frame angular velocity of the IMU, rad/s
    'K',                # (3, 3) float64 intrinsics of the rectified left camera
    'b',                # float stereo baseline, m
    'cam_T_imu',        # (4, 4) float64 IMU frame -> left camera optical frame (as used)
    'image_size',       # (width, height) ints, or None when the file does not say
    'extrinsic_fixed',  # True when the 2019 translation was corrected on loading
    'twist_axes',       # twist_axes.Verdict of the twist against the images, or None (not checked)
    'specific_force',   # (3, T) float64 accelerometer, m/s^2, IMU frame, mean over (t_k-1, t_k]
                        # in the body frame at t_k, gravity included; None when the file has none
    'columns_shared',   # True when a column of features may hold several tracks, one after the
                        # other (COLUMNS_SHARED_KEY); else each id is one track
]


class Dataset(collections.namedtuple('Dataset', _DATASET_FIELDS)):
    """A validated dataset; see the field comments in dataset.py for units and frames."""
    __slots__ = ()

    @property
    def twist_axes_turned(self):
        """True when the twist was turned into the extrinsic's axes on loading."""
        return self.twist_axes is not None and self.twist_axes.turn

    @property
    def num_frames(self):
        return self.t.shape[0]

    @property
    def num_ids(self):
        return self.features.shape[1]

    def observed(self):
        """(M, T) bool, True where id j is observed at frame k."""
        return observed_mask(self.features)


class DatasetError(ValueError):
    """A dataset that cannot be used; the message names the file and the field."""


def observed_mask(features):
    """(4, M, T) features -> (M, T) bool, True where the id is observed (not all four are -1)."""
    return ~np.all(features == UNOBSERVED, axis=0)


def load_dataset(path, fix_extrinsic=True, fix_twist_axes=True):
    """Read and validate a course npz file -> `Dataset`; raises `DatasetError` on any problem.

    fix_extrinsic: for the 2019 layout without the simulator's marker key, replace the stored
    cam_T_imu translation t by the correct -R @ t (`Dataset.extrinsic_fixed` says whether it did).
    fix_twist_axes: check the twist's axes against the tracks (`twist_axes.check`, about a second)
    and turn a twist that turns the other way into the extrinsic's axes (`Dataset.twist_axes`).
    """
    archive = _open_npz(path)
    try:
        dataset = _load_from_archive(path, archive, fix_extrinsic)
    finally:
        archive.close()
    if not fix_twist_axes:
        return dataset
    verdict = twist_axes.check(dataset)
    if verdict.turn:
        dataset = dataset._replace(v=twist_axes.HALF_TURN_X @ dataset.v,
                                   w=twist_axes.HALF_TURN_X @ dataset.w)
    return dataset._replace(twist_axes=verdict)


# ---------------------------------------------------------------------------------------------
# Reading
# ---------------------------------------------------------------------------------------------
def _open_npz(path):
    try:
        archive = np.load(path, allow_pickle=False)
    except FileNotFoundError:
        raise DatasetError('%s: no such file' % path)
    except IsADirectoryError:
        raise DatasetError('%s: is a directory, not an npz file' % path)
    except (OSError, ValueError, EOFError, zipfile.BadZipFile, zlib.error) as exc:
        raise DatasetError('%s: not a readable npz archive (%s)' % (path, _short(exc)))
    if not isinstance(archive, np.lib.npyio.NpzFile):
        raise DatasetError('%s: a single .npy array, not an npz archive of named fields' % path)
    return archive


def _read_field(path, archive, key):
    """One array of the archive; corrupt members and pickled (object) arrays -> DatasetError."""
    try:
        value = archive[key]
    except ValueError as exc:
        if 'allow_pickle' in str(exc) or 'Object arrays' in str(exc):
            raise DatasetError("%s: field '%s': object array (would need pickle; refused), "
                               "store a numeric array" % (path, key))
        raise DatasetError("%s: field '%s': cannot read (%s)" % (path, key, _short(exc)))
    except (OSError, EOFError, zipfile.BadZipFile, zlib.error, KeyError) as exc:
        raise DatasetError("%s: field '%s': cannot read, file truncated or corrupt (%s)"
                           % (path, key, _short(exc)))
    if value.dtype == object:
        raise DatasetError("%s: field '%s': object array, store a numeric array" % (path, key))
    return value


#: What a missing required field's message adds.
_MISSING_HINTS = {
    'linear_velocity': ": no twist (track_stereo_images writes one, from the poses, only with "
                       "--poses; a robot's comes from its IMU or wheel odometry)",
}


def _pick_key(path, archive, names, required=True):
    """The one of `names` present in the archive (None if optional and absent)."""
    present = [n for n in names if n in archive.files]
    if len(present) > 1:
        raise DatasetError('%s: fields %s are alternatives; keep only one'
                           % (path, ' and '.join("'%s'" % n for n in present)))
    if not present:
        if not required:
            return None
        if len(names) == 1:
            raise DatasetError("%s: missing field '%s'%s"
                               % (path, names[0], _MISSING_HINTS.get(names[0], '')))
        raise DatasetError("%s: missing field '%s' (or %s)"
                           % (path, names[0], ', '.join("'%s'" % n for n in names[1:])))
    return present[0]


def _short(exc):
    text = str(exc).strip().splitlines()
    return text[0] if text else type(exc).__name__


# ---------------------------------------------------------------------------------------------
# Validation
# ---------------------------------------------------------------------------------------------
def _numeric(path, key, value):
    """Real numeric (int/float, not bool/complex/str) -> float64 copy."""
    if value.dtype.kind not in 'iuf':
        raise DatasetError("%s: field '%s': dtype %s is not numeric" % (path, key, value.dtype))
    return np.array(value, dtype=np.float64)


def _first_bad_frame(values):
    """Index along the last axis of the first non-finite entry of `values`, or None."""
    bad = ~np.isfinite(values)
    if not bad.any():
        return None
    return int(np.argmax(bad.reshape(-1, values.shape[-1]).any(axis=0)))


def _require_finite_per_frame(path, key, values):
    frame = _first_bad_frame(values)
    if frame is not None:
        raise DatasetError("%s: field '%s': non-finite value at frame %d" % (path, key, frame))


def _time_stamps(path, key, raw):
    t = _numeric(path, key, raw)
    if t.ndim == 2 and 1 in t.shape:
        t = t.reshape(-1)
    if t.ndim != 1:
        raise DatasetError("%s: field '%s': shape %s, expected (T,), (1,T) or (T,1)"
                           % (path, key, raw.shape))
    if t.size == 0:
        raise DatasetError("%s: field '%s': no frames" % (path, key))
    _require_finite_per_frame(path, key, t)
    if t[0] < 0:
        raise DatasetError("%s: field '%s': negative time stamp at frame 0" % (path, key))
    steps = np.diff(t)
    if np.any(steps <= 0):
        k = int(np.argmax(steps <= 0)) + 1
        raise DatasetError("%s: field '%s': not strictly increasing at frame %d "
                           "(%.6f after %.6f)" % (path, key, k, t[k], t[k - 1]))
    return t


def _velocity(path, key, raw, num):
    """A (3, T) per-frame vector field (twist, specific force), finite."""
    v = _numeric(path, key, raw)
    if v.shape != (3, num):
        raise DatasetError("%s: field '%s': shape %s, expected (3, %d) (3 x number of frames)"
                           % (path, key, raw.shape, num))
    _require_finite_per_frame(path, key, v)
    return v


def _features(path, key, raw, num):
    f = _numeric(path, key, raw)
    if f.ndim != 3 or f.shape[0] != 4 or f.shape[2] != num:
        raise DatasetError("%s: field '%s': shape %s, expected (4, M, %d) (4 x ids x frames)"
                           % (path, key, raw.shape, num))
    _require_finite_per_frame(path, key, f)
    return f


def _intrinsics(path, key, raw):
    K = _numeric(path, key, raw)
    if K.shape != (3, 3):
        raise DatasetError("%s: field '%s': shape %s, expected (3, 3)" % (path, key, raw.shape))
    if not np.all(np.isfinite(K)):
        raise DatasetError("%s: field '%s': non-finite value" % (path, key))
    if not (K[0, 0] > 0 and K[1, 1] > 0):
        raise DatasetError("%s: field '%s': focal lengths must be positive (fx=%g, fy=%g)"
                           % (path, key, K[0, 0], K[1, 1]))
    if not np.allclose(K[2], [0.0, 0.0, 1.0]):
        raise DatasetError("%s: field '%s': last row must be [0 0 1], got %s"
                           % (path, key, K[2].tolist()))
    return K


def _baseline(path, key, raw):
    b = _numeric(path, key, raw)
    if b.size != 1:
        raise DatasetError("%s: field '%s': shape %s, expected a scalar" % (path, key, raw.shape))
    b = float(b.reshape(()))
    if not np.isfinite(b) or b <= 0:
        raise DatasetError("%s: field '%s': baseline must be positive and finite, got %g"
                           % (path, key, b))
    return b


def _rigid_transform(path, key, raw):
    T = _numeric(path, key, raw)
    if T.shape != (4, 4):
        raise DatasetError("%s: field '%s': shape %s, expected (4, 4)" % (path, key, raw.shape))
    if not np.all(np.isfinite(T)):
        raise DatasetError("%s: field '%s': non-finite value" % (path, key))
    if not np.allclose(T[3], [0.0, 0.0, 0.0, 1.0], atol=1e-9):
        raise DatasetError("%s: field '%s': last row must be [0 0 0 1], got %s"
                           % (path, key, T[3].tolist()))
    R = T[:3, :3]
    err = np.abs(R.T @ R - np.eye(3)).max()
    if err >= _ORTHONORMAL_TOL:
        raise DatasetError("%s: field '%s': rotation is not orthonormal (|R^T R - I| = %.3g)"
                           % (path, key, err))
    if np.linalg.det(R) <= 0:
        raise DatasetError("%s: field '%s': rotation has determinant %.3g, expected +1"
                           % (path, key, np.linalg.det(R)))
    return T


def _image_size(path, key, raw):
    size = np.asarray(raw).reshape(-1)
    if size.size != 2 or size.dtype.kind not in 'iuf':
        raise DatasetError("%s: field '%s': expected [width, height], got %s"
                           % (path, key, np.asarray(raw).tolist()))
    if not np.all(np.isfinite(size)) or np.any(size <= 0) or np.any(size != np.round(size)):
        raise DatasetError("%s: field '%s': width and height must be positive integers, got %s"
                           % (path, key, size.tolist()))
    return int(size[0]), int(size[1])


def _flag(path, key, raw):
    value = np.asarray(raw)
    if value.size != 1 or value.dtype.kind not in 'biuf':
        raise DatasetError("%s: field '%s': expected a single boolean" % (path, key))
    return bool(value.reshape(()))


def _load_from_archive(path, archive, fix_extrinsic):
    def field(names, required=True):
        key = _pick_key(path, archive, names, required)
        return (key, None) if key is None else (key, _read_field(path, archive, key))

    # All keys first, so a missing one is named before any value problem.
    time_key = _pick_key(path, archive, ['time_stamps', 't'])
    for names in (['features'], ['linear_velocity'], ['rotational_velocity', 'angular_velocity'],
                  ['K'], ['b'], ['cam_T_imu', 'imu_T_cam']):
        _pick_key(path, archive, names)

    t = _time_stamps(path, time_key, _read_field(path, archive, time_key))
    num = t.shape[0]
    key, raw = field(['features'])
    features = _features(path, key, raw, num)
    key, raw = field(['linear_velocity'])
    v = _velocity(path, key, raw, num)
    key, raw = field(['rotational_velocity', 'angular_velocity'])
    w = _velocity(path, key, raw, num)
    key, raw = field(['K'])
    K = _intrinsics(path, key, raw)
    key, raw = field(['b'])
    b = _baseline(path, key, raw)
    key, raw = field(['image_size'], required=False)
    image_size = None if key is None else _image_size(path, key, raw)
    key, raw = field(['specific_force'], required=False)
    specific_force = None if key is None else _velocity(path, key, raw, num)
    key, raw = field([COLUMNS_SHARED_KEY], required=False)
    columns_shared = key is not None and _flag(path, key, raw)

    extrinsic_key, raw = field(['cam_T_imu', 'imu_T_cam'])
    stored = _rigid_transform(path, extrinsic_key, raw)
    extrinsic_fixed = False
    if extrinsic_key == 'imu_T_cam':
        layout = LAYOUT_LATER
        cam_T_imu = se3.inverse(stored)
    else:
        layout = LAYOUT_2019
        cam_T_imu = stored.copy()
        key, raw = field([TRANSLATION_CORRECT_KEY], required=False)
        translation_correct = key is not None and _flag(path, key, raw)
        if fix_extrinsic and not translation_correct:
            cam_T_imu[:3, 3] = -stored[:3, :3] @ stored[:3, 3]
            extrinsic_fixed = True

    return Dataset(path=path, layout=layout, t=t, features=features, v=v, w=w, K=K, b=b,
                   cam_T_imu=cam_T_imu, image_size=image_size, extrinsic_fixed=extrinsic_fixed,
                   twist_axes=None, specific_force=specific_force,
                   columns_shared=columns_shared)


def extrinsic_fix_notice(dataset):
    """One line explaining the 2019 translation fix, or None when nothing was changed."""
    if not dataset.extrinsic_fixed:
        return None
    t = dataset.cam_T_imu[:3, 3]
    return ('%s: 2019 layout: cam_T_imu translation corrected to -R t = (%.4f, %.4f, %.4f) m '
            '(the stored one is imu_T_cam\'s)' % (dataset.path, t[0], t[1], t[2]))


def twist_axes_notice(dataset):
    """One line explaining a turned twist, or None when the twist was kept."""
    if not dataset.twist_axes_turned:
        return None
    verdict = dataset.twist_axes
    return ('%s: the twist turns the other way than the images (its y and z axes against the '
            'extrinsic\'s): turned by a half turn about x (tracks predicted by the twist: '
            'median error per frame %.2f px as stored, %.2f px turned, mean over %d frames)'
            % (dataset.path, verdict.mean_stored_px, verdict.mean_turned_px, verdict.frames))
