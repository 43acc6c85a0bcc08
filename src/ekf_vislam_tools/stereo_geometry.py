"""Rectified stereo geometry of the left camera's optical frame (z forward, x right, y down).

An observation is [uL, vL, uR, vR] in pixels: the right camera sits `b` metres along +x of the
left one, both with the intrinsics K (fx, fy, cx, cy), so a point at depth z has disparity
uL - uR = fx b / z and the same row in both images. One implementation for the simulator, the
track statistics and the twist-axes check.
"""
import numpy as np


def project(p_cam, K, b):
    """Camera-frame points (N,3) -> (observations (N,4) [uL, vL, uR, vR], depth (N,)).

    Points at depth 0 give inf/NaN without a warning; callers mask by depth."""
    p_cam = np.asarray(p_cam, dtype=float)
    depth = p_cam[:, 2]
    with np.errstate(divide='ignore', invalid='ignore'):
        u = K[0, 0] * p_cam[:, 0] / depth + K[0, 2]
        v = K[1, 1] * p_cam[:, 1] / depth + K[1, 2]
        disparity = K[0, 0] * b / depth
        return np.stack([u, v, u - disparity, v], axis=1), depth


def project_jacobian(p_cam, K, b):
    """(N,4,3) derivative of `project`'s observations with respect to the camera-frame point."""
    p_cam = np.asarray(p_cam, dtype=float)
    x, y, z = p_cam[:, 0], p_cam[:, 1], p_cam[:, 2]
    fx, fy = K[0, 0], K[1, 1]
    d = np.zeros((p_cam.shape[0], 4, 3))
    d[:, 0, 0] = d[:, 2, 0] = fx / z
    d[:, 1, 1] = d[:, 3, 1] = fy / z
    d[:, 0, 2] = -fx * x / z ** 2
    d[:, 2, 2] = -fx * (x - b) / z ** 2
    d[:, 1, 2] = d[:, 3, 2] = -fy * y / z ** 2
    return d


def triangulate(z, K, b):
    """Observations (N,4) [uL, vL, uR, vR] -> camera-frame points (N,3), the row taken as the mean
    of vL and vR. Non-positive disparities give inf/NaN or points behind the camera: callers
    check the disparity first."""
    z = np.asarray(z, dtype=float)
    fx, fy, cx, cy = K[0, 0], K[1, 1], K[0, 2], K[1, 2]
    with np.errstate(divide='ignore', invalid='ignore'):
        depth = fx * b / (z[:, 0] - z[:, 2])
    v = 0.5 * (z[:, 1] + z[:, 3])
    return np.stack([(z[:, 0] - cx) * depth / fx, (v - cy) * depth / fy, depth], axis=1)
