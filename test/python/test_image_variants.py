"""ekf_vislam_tools.image_variants: the frame order, times, calibration and poses of an image
folder's variants agree with the geometry of the images they describe (points projected through
the source and through the variant land where the image operation puts them)."""
import sys
import unittest

import numpy as np

import ekf_test_paths

sys.path.insert(0, ekf_test_paths.SOURCE_DIR)
from ekf_vislam_tools import image_variants as iv  # noqa: E402
from ekf_vislam_tools import se3  # noqa: E402

K = np.array([[700.0, 0.0, 601.5], [0.0, 700.0, 183.0], [0.0, 0.0, 1.0]])
WIDTH, BASELINE = 1226, 0.54


def project(K, cam_T_world, p_world):
    p = (cam_T_world @ np.append(p_world, 1.0))[:3]
    return (K @ (p / p[2]))[:2]


def drive(n=6):
    """world_T_cam0 of a camera turning left while it drives forward (world = first camera)."""
    poses = []
    for k in range(n):
        T = np.eye(4)
        T[:3, :3] = se3.so3_exp(np.array([0.0, -0.02 * k, 0.0]))
        T[:3, 3] = [0.1 * k, 0.0, 1.2 * k]
        poses.append(T)
    return np.array(poses)


class ImageVariantsTest(unittest.TestCase):

    def test_frame_order(self):
        np.testing.assert_array_equal(iv.frame_order(7, 2, False), [0, 2, 4, 6])
        np.testing.assert_array_equal(iv.frame_order(7, 2, True), [6, 4, 2, 0])
        np.testing.assert_array_equal(iv.frame_order(5, 1, False, (1, 2)), [0, 1, 1, 1, 2, 3, 4])
        self.assertEqual(iv.parse_hold('3:10', 5), (3, 10))
        self.assertIsNone(iv.parse_hold(None, 5))
        for bad in ('5:1', '2:0', 'x', '1:2:3'):
            with self.assertRaises(ValueError):
                iv.parse_hold(bad, 5)

    def test_times_increase_with_the_source_intervals(self):
        times = np.array([0.0, 0.1, 0.2, 0.35, 0.45])
        np.testing.assert_allclose(iv.variant_times(times, iv.frame_order(5, 1, True)),
                                   [0.0, 0.1, 0.25, 0.35, 0.45])
        np.testing.assert_allclose(iv.variant_times(times, iv.frame_order(5, 2, False)),
                                   [0.0, 0.2, 0.45])
        # A held frame repeats at the median interval of the others (0.1 s here).
        np.testing.assert_allclose(iv.variant_times(times, iv.frame_order(5, 1, False, (1, 2))),
                                   [0.0, 0.1, 0.2, 0.3, 0.4, 0.55, 0.65])

    def test_scaled_calibration_maps_pixel_centres(self):
        """A pixel's centre u maps to s (u + 0.5) - 0.5 in an image resized by s."""
        scale = 0.5
        K_scaled = iv.scaled_calibration(K, scale)
        p = np.array([1.3, -0.4, 9.0])
        u = project(K, np.eye(4), p)
        np.testing.assert_allclose(project(K_scaled, np.eye(4), p), scale * (u + 0.5) - 0.5)

    def test_mirrored_poses_see_the_flipped_exchanged_images(self):
        """Each world point seen by the source's right camera at pixel (u, v) is seen by the
        variant's left camera, in the mirrored world, at (width - 1 - u, v), and the source's
        left camera's view lands in the variant's right camera; order, reversal and the new
        world origin included."""
        poses = drive()
        order = iv.frame_order(len(poses), 1, True)
        variant = iv.variant_poses(poses, order, True, BASELINE)
        np.testing.assert_allclose(variant[0], np.eye(4), atol=1e-12)
        K_mirrored = iv.mirrored_calibration(K, WIDTH)
        # The variant's world in the source's: mirror, from the first variant frame's camera.
        source_first_right = poses[order[0]].copy()
        source_first_right[:3, 3] += BASELINE * poses[order[0]][:3, 0]
        rng = np.random.default_rng(1)
        for k, i in enumerate(order):
            world_T_left = poses[i]
            world_T_right = world_T_left.copy()
            world_T_right[:3, 3] += BASELINE * world_T_left[:3, 0]
            variant_right = variant[k].copy()
            variant_right[:3, 3] += BASELINE * variant[k][:3, 0]
            for _ in range(5):
                p_cam = np.array([rng.uniform(-5, 5), rng.uniform(-1, 1), rng.uniform(5, 40)])
                p_world = (world_T_left @ np.append(p_cam, 1.0))[:3]
                # The same point in the variant's world: mirrored about the first camera.
                p_first = (se3.inverse(source_first_right) @ np.append(p_world, 1.0))[:3]
                p_variant = iv.MIRROR[:3, :3] @ p_first
                for source_cam, variant_cam in ((world_T_right, variant[k]),
                                                (world_T_left, variant_right)):
                    u = project(K, se3.inverse(source_cam), p_world)
                    expected = np.array([WIDTH - 1 - u[0], u[1]])
                    np.testing.assert_allclose(
                        project(K_mirrored, se3.inverse(variant_cam), p_variant), expected,
                        atol=1e-6)
                # Rectified still: the variant's right camera sits the baseline along its x.
                self.assertAlmostEqual(
                    (se3.inverse(variant[k]) @ variant_right)[0, 3], BASELINE, places=9)

    def test_right_image_warp_turns_clockwise_about_the_principal_point(self):
        """--right-roll: a positive roll turns the right image clockwise as displayed (points right
        of the principal point go down, the rig check's sign), about the principal point, and
        --right-shift moves it right after the turn."""
        self.assertIsNone(iv.right_image_warp(0.0, 0.0, (K[0, 2], K[1, 2])))
        warp = iv.right_image_warp(2.0, 0.5, (K[0, 2], K[1, 2]))

        def moved(u, v):
            return warp @ np.array([u, v, 1.0])

        np.testing.assert_allclose(moved(K[0, 2], K[1, 2]), [K[0, 2] + 2.0, K[1, 2]], atol=1e-9)
        right = moved(K[0, 2] + 100.0, K[1, 2])
        self.assertAlmostEqual(right[1] - K[1, 2], 100.0 * np.sin(np.radians(0.5)), places=9)
        below = moved(K[0, 2], K[1, 2] + 100.0)
        self.assertAlmostEqual(below[0] - (K[0, 2] + 2.0), -100.0 * np.sin(np.radians(0.5)),
                               places=9)
        shift_only = iv.right_image_warp(1.0, 0.0, (K[0, 2], K[1, 2]))
        np.testing.assert_array_equal(shift_only, [[1.0, 0.0, 1.0], [0.0, 1.0, 0.0]])


if __name__ == '__main__':
    unittest.main()
