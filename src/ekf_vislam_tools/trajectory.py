"""Trajectory files: TUM ("t tx ty tz qx qy qz qw") and KITTI odometry poses (3x4 per line)."""
import numpy as np

from ekf_vislam_tools import se3


class TrajectoryError(ValueError):
    """A trajectory file that cannot be read; the message names the file and the problem."""


def read_tum(path):
    """-> (t[N], T[N,4,4]) of the poses in a TUM file (comments '#' allowed)."""
    try:
        data = np.loadtxt(path, comments='#', ndmin=2)
    except (OSError, ValueError) as exc:
        raise TrajectoryError('%s: cannot read TUM trajectory (%s)' % (path, exc))
    if data.shape[0] == 0 or data.shape[1] != 8:
        raise TrajectoryError('%s: expected 8 columns "t tx ty tz qx qy qz qw", got %d'
                              % (path, data.shape[1] if data.size else 0))
    if not np.all(np.isfinite(data)):
        raise TrajectoryError('%s: non-finite values' % path)
    T = np.tile(np.eye(4), (data.shape[0], 1, 1))
    for i, row in enumerate(data):
        T[i, :3, :3] = se3.quaternion_to_rotation(row[4:8])
        T[i, :3, 3] = row[1:4]
    return data[:, 0].copy(), T


def write_tum(path, t, T):
    with open(path, 'w') as f:
        for ti, Ti in zip(t, T):
            q = se3.rotation_to_quaternion(Ti[:3, :3])
            f.write('%.9f %.9f %.9f %.9f %.9f %.9f %.9f %.9f\n'
                    % (ti, Ti[0, 3], Ti[1, 3], Ti[2, 3], q[0], q[1], q[2], q[3]))


def read_kitti_poses(path):
    """-> T[N,4,4] from a KITTI odometry poses file (12 numbers per line, row-major 3x4)."""
    try:
        data = np.loadtxt(path, ndmin=2)
    except (OSError, ValueError) as exc:
        raise TrajectoryError('%s: cannot read KITTI poses (%s)' % (path, exc))
    if data.shape[1] != 12:
        raise TrajectoryError('%s: expected 12 numbers per line, got %d' % (path, data.shape[1]))
    T = np.tile(np.eye(4), (data.shape[0], 1, 1))
    T[:, :3, :4] = data.reshape(-1, 3, 4)
    return T


def read_groundtruth(path, frame_times=None, cam_T_imu=None):
    """Ground truth as world_T_imu -> (t[N], T[N,4,4]).

    A TUM file is taken as world_T_imu with its own times. A KITTI poses file (world_T_cam0) needs
    the frame times (line k = frame k; extra frames beyond the file are dropped) and cam_T_imu to
    become world_T_imu = world_T_cam0 * cam_T_imu.
    """
    with open(path) as f:
        first = ''
        for line in f:
            if line.strip() and not line.startswith('#'):
                first = line
                break
    ncols = len(first.split())
    if ncols == 8:
        return read_tum(path)
    if ncols == 12:
        if frame_times is None or cam_T_imu is None:
            raise TrajectoryError('%s: a KITTI poses file needs the dataset frame times and cam_T_imu'
                                  % path)
        world_T_cam = read_kitti_poses(path)
        n = min(len(world_T_cam), len(frame_times))
        T = np.array([world_T_cam[i] @ cam_T_imu for i in range(n)])
        return np.asarray(frame_times[:n], float), T
    raise TrajectoryError('%s: neither TUM (8 columns) nor KITTI poses (12 columns)' % path)
