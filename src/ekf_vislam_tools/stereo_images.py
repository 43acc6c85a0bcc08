"""Stereo image folders in the KITTI odometry layout (image_left/ and image_right/, or KITTI's own
image_0/ and image_1/; calib.txt with P0 and P1, times.txt, optional poses.txt with world_T_cam0
per line) and the ground-truth twist of
a vehicle frame (x along the direction of travel, y left, z up) rigidly attached at the left
camera, as track_stereo_images writes it (sample k+1 drives [t_k, t_k+1]; white noise and a gyro
offset)."""
import collections
import os

import numpy as np

from ekf_vislam_tools import se3

IMAGE_EXTENSIONS = ('.png', '.jpg', '.jpeg', '.pgm', '.ppm')

#: cam_T_imu of the IMU frame x forward, y left, z up at the left camera's origin.
CAM_T_IMU = np.array([[0.0, -1.0, 0.0, 0.0],
                      [0.0, 0.0, -1.0, 0.0],
                      [1.0, 0.0, 0.0, 0.0],
                      [0.0, 0.0, 0.0, 1.0]])


def travel_aligned_cam_T_imu(world_T_cam, min_distance=1.0):
    """cam_T_imu of a vehicle frame at the left camera's origin, as track_stereo_images makes it:
    x along the camera's direction of travel (the sum of its steps' body velocities: each step's
    SE(3) logarithm, in the camera frame it starts from; in a turn a step's chord leans into it),
    z up (the camera's -y made orthogonal to x), y left. A ground vehicle's body
    velocity lies along this x, so the estimator's vehicle prior holds for a twist in these axes.
    CAM_T_IMU when the poses travel less than min_distance m or mostly backwards."""
    travel = np.zeros(3)
    distance = 0.0
    for k in range(len(world_T_cam) - 1):
        step = se3_log(se3.inverse(world_T_cam[k]) @ world_T_cam[k + 1])[:3]
        travel += step
        distance += np.linalg.norm(step)
    cam_T_imu = CAM_T_IMU.copy()
    if not distance >= min_distance or not travel[2] > 0.5 * np.linalg.norm(travel):
        return cam_T_imu
    x = travel / np.linalg.norm(travel)
    up = np.array([0.0, -1.0, 0.0])
    z = up - up.dot(x) * x
    z /= np.linalg.norm(z)
    cam_T_imu[:3, 0], cam_T_imu[:3, 1], cam_T_imu[:3, 2] = x, np.cross(z, x), z
    return cam_T_imu


StereoFolder = collections.namedtuple(
    'StereoFolder', ['left', 'right', 'times', 'K', 'b', 'world_T_cam'])


def list_images(folder):
    names = sorted(n for n in os.listdir(folder) if n.lower().endswith(IMAGE_EXTENSIONS))
    if not names:
        raise ValueError('%s: no images' % folder)
    return [os.path.join(folder, n) for n in names]


def read_calib(path):
    """calib.txt -> (K 3x3, baseline m), from P0 and P1 (optionally labelled 'P0:')."""
    rows = {}
    unlabeled = []
    with open(path) as f:
        for line in f:
            parts = line.split()
            if not parts:
                continue
            if parts[0].endswith(':'):
                rows[parts[0][:-1]] = [float(x) for x in parts[1:]]
            else:
                unlabeled.append([float(x) for x in parts])
    p0 = rows.get('P0', unlabeled[0] if unlabeled else None)
    p1 = rows.get('P1', unlabeled[1] if len(unlabeled) > 1 else None)
    if p0 is None or p1 is None or len(p0) != 12 or len(p1) != 12:
        raise ValueError('%s: needs P0 and P1 (12 numbers each)' % path)
    P0, P1 = np.reshape(p0, (3, 4)), np.reshape(p1, (3, 4))
    return P0[:, :3].copy(), (P0[0, 3] - P1[0, 3]) / P0[0, 0]


def read_poses(path):
    """poses.txt -> (N, 4, 4) world_T_cam."""
    rows = np.loadtxt(path, ndmin=2)
    if rows.shape[1] != 12:
        raise ValueError('%s: expected 12 numbers per line' % path)
    T = np.tile(np.eye(4), (rows.shape[0], 1, 1))
    T[:, :3, :] = rows.reshape(-1, 3, 4)
    return T


def image_folders(folder):
    """(left, right) image folders of a sequence folder: image_left/ and image_right/ when either
    is there (the package's own layout; a missing one is then named), else KITTI's image_0/ and
    image_1/."""
    own = [os.path.join(folder, side) for side in ('image_left', 'image_right')]
    if any(os.path.isdir(path) for path in own):
        return tuple(own)
    return os.path.join(folder, 'image_0'), os.path.join(folder, 'image_1')


def load_folder(folder=None, left=None, right=None, calib=None, times=None, poses=None):
    """A KITTI-layout folder (or its parts given one by one) -> StereoFolder."""
    if folder is not None:
        found_left, found_right = image_folders(folder)
        left, right = left or found_left, right or found_right
    calib = calib or os.path.join(folder, 'calib.txt')
    times = times or os.path.join(folder, 'times.txt')
    if poses is None and folder is not None and os.path.exists(os.path.join(folder, 'poses.txt')):
        poses = os.path.join(folder, 'poses.txt')
    K, b = read_calib(calib)
    t = np.loadtxt(times, ndmin=1)
    lefts, rights = list_images(left), list_images(right)
    world_T_cam = read_poses(poses) if poses else None
    n = len(lefts)
    if len(rights) != n or len(t) != n or (world_T_cam is not None and len(world_T_cam) != n):
        raise ValueError('frame counts differ: %d left, %d right, %d times%s'
                         % (n, len(rights), len(t), '' if world_T_cam is None
                            else ', %d poses' % len(world_T_cam)))
    return StereoFolder(lefts, rights, t, K, b, world_T_cam)


def write_metadata(folder, K, b, times, world_T_cam=None):
    """calib.txt (P0, P1 of a rectified pair: K, the right camera b m along the left's x),
    times.txt and, given world_T_cam (N, 4, 4), poses.txt: what load_folder reads back."""
    P0 = np.hstack([K, np.zeros((3, 1))])
    P1 = P0.copy()
    P1[0, 3] = -K[0, 0] * b
    with open(os.path.join(folder, 'calib.txt'), 'w') as f:
        f.write('P0: %s\nP1: %s\n' % (' '.join('%.12e' % x for x in P0.reshape(-1)),
                                      ' '.join('%.12e' % x for x in P1.reshape(-1))))
    np.savetxt(os.path.join(folder, 'times.txt'), times, fmt='%.9f')
    if world_T_cam is not None:
        rows = np.asarray(world_T_cam)[:, :3, :].reshape(len(world_T_cam), -1)
        np.savetxt(os.path.join(folder, 'poses.txt'), rows, fmt='%.9e')


def se3_log(T):
    """4x4 -> xi = [rho; phi] with T = exp(hat(xi))."""
    phi = se3.so3_log(T[:3, :3])
    theta = np.linalg.norm(phi)
    Phi = se3.hat(phi)
    if theta < 1e-9:
        V = np.eye(3) + 0.5 * Phi
    else:
        V = (np.eye(3) + (1 - np.cos(theta)) / theta ** 2 * Phi
             + (theta - np.sin(theta)) / theta ** 3 * Phi @ Phi)
    return np.concatenate([np.linalg.solve(V, T[:3, 3]), phi])


def twist_from_poses(world_T_imu, times, linear_sigma=0.05, angular_sigma=0.005,
                     gyro_offset=0.001, seed=0):
    """(v, w), each (3, T): sample k+1 = log(inv(T_k) T_k+1) / dt; sample 0 copies sample 1;
    plus white noise and a constant offset on every gyro axis."""
    n = len(times)
    xi = np.zeros((6, n))
    for k in range(n - 1):
        xi[:, k + 1] = se3_log(se3.inverse(world_T_imu[k]) @ world_T_imu[k + 1]) / (
            times[k + 1] - times[k])
    if n > 1:
        xi[:, 0] = xi[:, 1]
    rng = np.random.default_rng(seed)
    v = xi[:3] + linear_sigma * rng.standard_normal((3, n))
    w = xi[3:] + angular_sigma * rng.standard_normal((3, n)) + gyro_offset
    return v, w
