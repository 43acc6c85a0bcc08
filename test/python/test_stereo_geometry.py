"""Tests of the rectified stereo geometry (ekf_vislam_tools.stereo_geometry)."""
import unittest

import numpy as np

import ekf_test_paths  # noqa: F401 (puts the package's Python modules on the path)
from ekf_vislam_tools import stereo_geometry

K = np.array([[718.856, 0.0, 607.1928], [0.0, 718.856, 185.2157], [0.0, 0.0, 1.0]])
BASELINE = 0.537


def random_points(seed, n=50):
    rng = np.random.default_rng(seed)
    return np.stack([rng.uniform(-10, 10, n), rng.uniform(-3, 3, n), rng.uniform(2, 60, n)], 1)


class StereoGeometryTest(unittest.TestCase):
    def test_projection_follows_the_rectified_pinhole_model(self):
        z, depth = stereo_geometry.project(np.array([[2.0, -1.0, 10.0]]), K, BASELINE)
        fx, cx, cy = K[0, 0], K[0, 2], K[1, 2]
        np.testing.assert_allclose(z[0], [fx * 0.2 + cx, fx * -0.1 + cy,
                                          fx * (2.0 - BASELINE) / 10.0 + cx, fx * -0.1 + cy],
                                   rtol=0, atol=1e-9)
        self.assertEqual(depth[0], 10.0)

    def test_triangulation_inverts_the_projection(self):
        points = random_points(1)
        z, _ = stereo_geometry.project(points, K, BASELINE)
        np.testing.assert_allclose(stereo_geometry.triangulate(z, K, BASELINE), points,
                                   rtol=1e-12, atol=1e-9)

    def test_triangulation_takes_the_mean_row(self):
        z, _ = stereo_geometry.project(random_points(2, 1), K, BASELINE)
        shifted = z.copy()
        shifted[:, 1] += 0.5
        shifted[:, 3] -= 0.5
        np.testing.assert_allclose(stereo_geometry.triangulate(shifted, K, BASELINE),
                                   stereo_geometry.triangulate(z, K, BASELINE), atol=1e-9)

    def test_jacobian_against_central_differences(self):
        points = random_points(3, 20)
        analytic = stereo_geometry.project_jacobian(points, K, BASELINE)
        step = 1e-6
        for axis in range(3):
            delta = np.zeros(3)
            delta[axis] = step
            plus, _ = stereo_geometry.project(points + delta, K, BASELINE)
            minus, _ = stereo_geometry.project(points - delta, K, BASELINE)
            np.testing.assert_allclose(analytic[:, :, axis], (plus - minus) / (2 * step),
                                       rtol=1e-6, atol=1e-5)

    def test_points_at_depth_zero_do_not_warn(self):
        with np.errstate(all='raise'):
            z, depth = stereo_geometry.project(np.array([[1.0, 1.0, 0.0]]), K, BASELINE)
            p = stereo_geometry.triangulate(np.array([[100.0, 50.0, 100.0, 50.0]]), K, BASELINE)
        self.assertEqual(depth[0], 0.0)
        self.assertFalse(np.all(np.isfinite(z)))
        self.assertFalse(np.all(np.isfinite(p)))


if __name__ == '__main__':
    unittest.main()
