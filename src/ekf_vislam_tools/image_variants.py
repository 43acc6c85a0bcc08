"""Another regime of a stereo image folder (KITTI odometry layout, `stereo_images`): the frame
order (every Nth frame, reversed, a held frame), the times, poses and calibration that go with
it, mirrored or rescaled. scripts/image_variant.py writes the images."""
import numpy as np

from ekf_vislam_tools import se3

#: x -> -x: a mirror of the world and of each camera frame (M T M is again a rigid motion).
MIRROR = np.diag([-1.0, 1.0, 1.0, 1.0])


def frame_order(n, step, reverse, hold=None):
    """Indices of the source frames, in the variant's order; hold = (K, N): its frame K N more
    times."""
    order = np.arange(0, n, step)
    if reverse:
        order = order[::-1]
    if hold is not None:
        k, count = hold
        order = np.insert(order, k + 1, np.full(count, order[k]))
    return order


def variant_times(times, order):
    """Times of the variant's frames, from the source's first time on: each interval between
    two source frames kept (reversed: the same length), a held frame's the median interval."""
    t = times[order]
    steps = np.abs(np.diff(t))
    moving = steps[steps > 0]
    steps[steps == 0] = np.median(moving) if len(moving) else 0.1
    return times[0] + np.concatenate([[0.0], np.cumsum(steps)])


def parse_hold(text, n):
    """'K:N' -> (K, N), K a frame of the variant (0..n-1), N >= 1; None for None."""
    if text is None:
        return None
    try:
        k, count = (int(x) for x in text.split(':'))
    except ValueError:
        k, count = -1, 0
    if not 0 <= k < n or count < 1:
        raise ValueError('--hold K:N needs 0 <= K < %d and N >= 1' % n)
    return k, count


def mirrored_calibration(K, width):
    """K of images flipped left to right: cx -> width - 1 - cx."""
    K = K.copy()
    K[0, 2] = width - 1 - K[0, 2]
    return K


def scaled_calibration(K, scale):
    """K of images resized by `scale`, about the pixel centres."""
    K = K.copy()
    K[0, 0] *= scale
    K[1, 1] *= scale
    K[0, 2] = scale * (K[0, 2] + 0.5) - 0.5
    K[1, 2] = scale * (K[1, 2] + 0.5) - 0.5
    return K


def variant_poses(world_T_cam, order, mirror, baseline):
    """world_T_cam0 of the variant's left camera, with the world at its first frame. Mirrored,
    that camera is the source's right one (world_T_cam0 * [I, (b, 0, 0)]), seen in a mirror."""
    poses = world_T_cam[order].copy()
    if mirror:
        cam0_T_cam1 = np.eye(4)
        cam0_T_cam1[0, 3] = baseline
        poses = np.array([MIRROR @ T @ cam0_T_cam1 @ MIRROR for T in poses])
    first_inv = se3.inverse(poses[0])
    return np.array([first_inv @ T for T in poses])


def right_image_warp(shift, roll_deg, principal_point):
    """The 2x3 map (cv2.warpAffine, source to copy) of a right image's pixels: turned roll_deg
    clockwise as displayed about the principal point (x right, y down), then moved shift px
    right. None for no change."""
    if shift == 0.0 and roll_deg == 0.0:
        return None
    # OpenCV's getRotationMatrix2D turns anticlockwise as displayed for a positive angle; this is
    # the same matrix for the negated angle.
    angle = np.radians(roll_deg)
    c, s = np.cos(angle), np.sin(angle)
    cx, cy = principal_point
    return np.array([[c, -s, (1 - c) * cx + s * cy + shift],
                     [s, c, -s * cx + (1 - c) * cy]])
