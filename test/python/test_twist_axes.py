"""Tests of the twist-axes check (ekf_vislam_tools.twist_axes) and its use on loading a dataset."""
import os
import subprocess
import unittest

import numpy as np

import ekf_test_paths as paths
from ekf_vislam_tools import simulator, twist_axes
from ekf_vislam_tools.dataset import load_dataset, twist_axes_notice

PROG = os.path.join(paths.SCRIPTS_DIR, 'dataset_to_bag.py')


def simulated_arrays(seed, frames=150, **options):
    """A short simulated drive in the 2019 layout (twist and extrinsic agree)."""
    return simulator.dataset_arrays(simulator.simulate(seed, frames=frames, **options))


def turned(arrays):
    """The same file with its twist given in axes turned by a half turn about x."""
    arrays = dict(arrays)
    arrays['linear_velocity'] = twist_axes.HALF_TURN_X @ arrays['linear_velocity']
    arrays['rotational_velocity'] = twist_axes.HALF_TURN_X @ arrays['rotational_velocity']
    return arrays


class TwistAxesTest(unittest.TestCase):
    def setUp(self):
        self.tmp = paths.make_temp_dir(self)

    def write(self, name, arrays):
        path = os.path.join(self.tmp, name)
        np.savez(path, **arrays)
        return path

    def test_agreeing_twist_is_kept(self):
        for seed in (1, 2):
            dataset = load_dataset(self.write('agree.npz', simulated_arrays(seed)))
            verdict = dataset.twist_axes
            self.assertFalse(verdict.turn)
            self.assertFalse(dataset.twist_axes_turned)
            self.assertGreater(verdict.pairs, 1000)
            # The course-like twist noise (0.5 m/s, 0.05 rad/s) leaves a few px; turned, the yaw
            # and pitch rates point the wrong way.
            self.assertGreater(verdict.median_turned_px, 1.5 * verdict.median_stored_px)
            self.assertIsNone(twist_axes_notice(dataset))

    def test_turned_twist_is_found_and_turned_back(self):
        arrays = simulated_arrays(3)
        dataset = load_dataset(self.write('turned.npz', turned(arrays)))
        self.assertTrue(dataset.twist_axes_turned)
        verdict = dataset.twist_axes
        self.assertLess(verdict.median_turned_px,
                        twist_axes.DECISIVE_RATIO * verdict.median_stored_px)
        np.testing.assert_allclose(dataset.v, arrays['linear_velocity'], atol=1e-12)
        np.testing.assert_allclose(dataset.w, arrays['rotational_velocity'], atol=1e-12)
        self.assertIn('half turn about x', twist_axes_notice(dataset))

    def test_accurate_twist_decides_by_a_wide_margin(self):
        arrays = simulated_arrays(4, velocity_noise=0.05, gyro_noise=0.005, gyro_bias=0.001)
        kept = load_dataset(self.write('accurate.npz', arrays)).twist_axes
        self.assertFalse(kept.turn)
        self.assertGreater(kept.median_turned_px, 4.0 * kept.median_stored_px)
        found = load_dataset(self.write('accurate_turned.npz', turned(arrays))).twist_axes
        self.assertTrue(found.turn)

    def test_too_few_tracks_give_no_verdict(self):
        arrays = turned(simulated_arrays(5, frames=3))
        dataset = load_dataset(self.write('short.npz', arrays))
        self.assertFalse(dataset.twist_axes.turn)
        self.assertLess(dataset.twist_axes.pairs, twist_axes.MIN_PAIRS)
        np.testing.assert_array_equal(dataset.w, arrays['rotational_velocity'])

    def test_check_can_be_skipped(self):
        arrays = turned(simulated_arrays(3))
        dataset = load_dataset(self.write('turned.npz', arrays), fix_twist_axes=False)
        self.assertIsNone(dataset.twist_axes)
        np.testing.assert_array_equal(dataset.w, arrays['rotational_velocity'])

    def test_bag_carries_the_turned_twist_and_says_so(self):
        import rosbag
        arrays = simulated_arrays(3)
        npz = self.write('turned.npz', turned(arrays))
        for extra, expect_turned in (([], True), (['--no-fix-twist-axes'], False)):
            bag = os.path.join(self.tmp, 'out.bag')
            proc = subprocess.run([paths.PYTHON, PROG, npz, bag] + extra, capture_output=True,
                                  text=True)
            self.assertEqual(proc.returncode, 0, proc.stderr)
            self.assertEqual('half turn about x' in proc.stderr, expect_turned, proc.stderr)
            with rosbag.Bag(bag) as reader:
                msg = next(m for _, m, _ in reader.read_messages(topics=['/imu/twist']))
            expected = arrays['rotational_velocity'][:, 0]
            if not expect_turned:
                expected = twist_axes.HALF_TURN_X @ expected
            a = msg.twist.angular
            np.testing.assert_allclose([a.x, a.y, a.z], expected, atol=1e-9)


@unittest.skipUnless(paths.data_dir(), 'course datasets not found (../shared/data or EKF_VISLAM_DATA)')
class CourseFilesTest(unittest.TestCase):
    """The KITTI-360 course file's twist turns against its extrinsic; the KITTI ones agree."""

    def test_course_files(self):
        expected = {'03': True, '0022': False, '0027': False, '0034': False}
        for name, turn in expected.items():
            path = paths.data_file(name + '.npz')
            if path is None:
                continue
            verdict = load_dataset(path).twist_axes
            print('%s: median error %.2f px stored, %.2f px turned' % (
                name, verdict.median_stored_px, verdict.median_turned_px))
            self.assertEqual(verdict.turn, turn, name)


if __name__ == '__main__':
    unittest.main()
