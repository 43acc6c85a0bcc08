"""A raw stereo camera made from a rectified image folder: the images the cameras would take
before rectification, with the camera_info of a calibrated rig (K, D, R, P), for the tracker's
ros/rectify (play_stereo_images.py --raw-camera).

Each raw camera has its own lens (by default plumb_bob, a barrel distortion like that of KITTI's
raw cameras: k1 -0.26, which moves the corners of a 1241x376 image by 170-195 px; or
rational_polynomial, or equidistant, a fisheye's; a focal length 3 % longer than the rectified
one; a principal point a few pixels off) and is turned from its rectified camera by 0.65 (left)
and 0.48 degrees (right), as a real rig's two cameras are. The rectified images are the folder's:
rectifying the raw images with these camera_info gives them back (up to two interpolations), and
the rectified projections P are the folder's calibration.
"""
import cv2
import numpy as np

from ekf_vislam_tools import se3

# Per camera (left, right): the distortion coefficients of each model, in camera_info's order, the
# turn R from the raw camera to the rectified one as a rotation vector (rad), and the raw
# intrinsics relative to the rectified ones.
DISTORTION = {
    # k1, k2, p1, p2, k3
    'plumb_bob': ((-0.26, 0.08, 4e-4, -3e-4, -0.01), (-0.25, 0.07, -2e-4, 5e-4, -0.008)),
    # k1, k2, p1, p2, k3, then the denominator's k4, k5, k6
    'rational_polynomial': ((-0.22, 0.05, 4e-4, -3e-4, -0.006, 0.04, 0.01, 0.002),
                            (-0.21, 0.045, -2e-4, 5e-4, -0.005, 0.035, 0.012, 0.001)),
    # theta's polynomial k1-k4 on the equidistant fisheye (radius f theta)
    'equidistant': ((0.03, -0.012, 0.004, -0.001), (0.025, -0.01, 0.003, -0.0008)),
}
DISTORTION_MODELS = tuple(DISTORTION)
ROTATION_VECTOR = ((0.0044, 0.0105, 0.0), (-0.0031, -0.0070, 0.0035))
FOCAL_SCALE = 1.03
PRINCIPAL_POINT_OFFSET = ((5.0, -4.0), (-3.0, 2.5))


class RawStereoCamera:
    """The raw rig of a rectified one (K, baseline b, image size (width, height)), its lenses of
    `distortion_model` (one of DISTORTION_MODELS)."""

    def __init__(self, K, b, image_size, distortion_model='plumb_bob'):
        self.width, self.height = image_size
        self.distortion_model = distortion_model
        self.P, self.K, self.D, self.R = [], [], [], []
        self._maps = []
        for side in (0, 1):
            P = np.zeros((3, 4))
            P[:, :3] = K
            P[0, 3] = -K[0, 0] * b if side == 1 else 0.0
            K_raw = K.copy()
            K_raw[0, 0] *= FOCAL_SCALE
            K_raw[1, 1] *= FOCAL_SCALE
            K_raw[0, 2] += PRINCIPAL_POINT_OFFSET[side][0]
            K_raw[1, 2] += PRINCIPAL_POINT_OFFSET[side][1]
            R = se3.so3_exp(np.array(ROTATION_VECTOR[side]))
            D = np.array(DISTORTION[distortion_model][side])
            self.P.append(P)
            self.K.append(K_raw)
            self.D.append(D)
            self.R.append(R)
            self._maps.append(self._raw_to_rectified_map(K_raw, D, R, P))

    def _raw_to_rectified_map(self, K_raw, D, R, P):
        """Where the rectified image sees each raw pixel (float32 maps for cv2.remap)."""
        u, v = np.meshgrid(np.arange(self.width, dtype=np.float64),
                           np.arange(self.height, dtype=np.float64))
        raw = np.stack([u.ravel(), v.ravel()], axis=1).reshape(-1, 1, 2)
        criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 50, 1e-9)
        if self.distortion_model == 'equidistant':
            rectified = cv2.fisheye.undistortPoints(raw, K_raw, D, R=R, P=P, criteria=criteria)
        else:
            rectified = cv2.undistortPointsIter(raw, K_raw, D, R, P, criteria)
        rectified = rectified.reshape(self.height, self.width, 2)
        return rectified[..., 0].astype(np.float32), rectified[..., 1].astype(np.float32)

    def raw_image(self, side, rectified):
        """The raw image (side 0 left, 1 right) of the scene whose rectified image is given."""
        map_x, map_y = self._maps[side]
        return cv2.remap(rectified, map_x, map_y, cv2.INTER_CUBIC, borderMode=cv2.BORDER_CONSTANT,
                         borderValue=0)

    def fill_camera_info(self, side, msg):
        """Sets a CameraInfo's size, distortion, K, R and P to the raw camera's."""
        msg.width, msg.height = self.width, self.height
        msg.distortion_model = self.distortion_model
        msg.D = [float(x) for x in self.D[side]]
        msg.K = [float(x) for x in self.K[side].reshape(-1)]
        msg.R = [float(x) for x in self.R[side].reshape(-1)]
        msg.P = [float(x) for x in self.P[side].reshape(-1)]

    def raw_T_rectified(self, side):
        """The rectified camera's pose in the raw camera's frame (x_rect = R x_raw)."""
        T = np.eye(4)
        T[:3, :3] = self.R[side].T
        return T
