"""make_variant.py --accel-noise / --accel-bias (ekf_vislam_tools.variants): the accelerometer from
the ground truth agrees with the simulator's own, gravity's up defaults to the mean IMU z axis,
the noise and offset are what was asked, and the twist and the kept ids do not change with it."""
import os
import sys
import unittest

import numpy as np

import ekf_test_paths

sys.path.insert(0, ekf_test_paths.SOURCE_DIR)
from ekf_vislam_tools import simulator, trajectory, variants  # noqa: E402


class MakeVariantAccelerometerTest(unittest.TestCase):

    FRAMES = 150

    @classmethod
    def setUpClass(cls):
        cls.tmp = ekf_test_paths.make_temp_dir()
        cls.addClassCleanup(ekf_test_paths.remove_dir, cls.tmp)
        # A hilly drive with the simulator's own noiseless accelerometer, the npz without it.
        cls.sim = simulator.simulate(4, frames=cls.FRAMES, roll_amplitude=3.0,
                                     pitch_amplitude=6.0, accel_noise=0.0)
        plain = dict(cls.sim)
        del plain['specific_force']
        paths = simulator.write_outputs(plain, os.path.join(cls.tmp, 'sim'))
        cls.npz, cls.gt = paths['npz'], paths['groundtruth']
        with np.load(cls.npz) as data:
            cls.data = {key: data[key] for key in data.files}

    def variant(self, name, *args):
        out = os.path.join(self.tmp, name + '.npz')
        proc = ekf_test_paths.run_script('make_variant.py', self.npz, '--groundtruth', self.gt,
                                         '--out', out, *args)
        self.assertEqual(proc.returncode, 0, proc.stderr)
        with np.load(out) as data:
            return {key: data[key] for key in data.files}

    def test_noiseless_equals_the_simulators_with_its_up(self):
        for twist in ('course', 'accurate'):
            with self.subTest(twist=twist):
                out, notes = variants.make_variant(self.data, self.gt, twist, accel_noise=0.0,
                                                   up_world=self.sim['up_world'])
                self.assertEqual(out['specific_force'].shape, (3, self.FRAMES))
                self.assertEqual(out['specific_force'].dtype, np.float64)
                # The TUM file's 9 decimals are the only difference.
                np.testing.assert_allclose(out['specific_force'], self.sim['specific_force'],
                                           rtol=0, atol=1e-5)
                self.assertIn('specific force from the ground truth', notes[-1])

    def test_default_up_is_the_mean_imu_z_axis(self):
        _, world_T_imu = trajectory.read_tum(self.gt)
        mean_z = world_T_imu[:, :3, 2].mean(axis=0)
        mean_z /= np.linalg.norm(mean_z)
        np.testing.assert_allclose(variants.mean_up_axis(world_T_imu), mean_z, atol=1e-15)
        force, up = variants.groundtruth_specific_force(self.sim['t'], *trajectory.read_tum(
            self.gt))
        np.testing.assert_allclose(up, mean_z, atol=1e-15)
        out, _ = variants.make_variant(self.data, self.gt, 'course', accel_noise=0.0)
        np.testing.assert_array_equal(out['specific_force'], force)
        with_mean = variants.make_variant(self.data, self.gt, 'course', accel_noise=0.0,
                                          up_world=3.0 * mean_z)[0]['specific_force']
        np.testing.assert_allclose(out['specific_force'], with_mean, atol=1e-12)
        # The gravity term uses that up: the same as the simulator's but for g R^T (up - up_sim).
        rotations = self.sim['world_T_imu'][:, :3, :3]
        shift = simulator.GRAVITY * np.einsum('kji,j->ik', rotations,
                                              mean_z - self.sim['up_world'])
        shift[:, 0] = shift[:, 1]  # sample 0 repeats sample 1
        np.testing.assert_allclose(out['specific_force'], self.sim['specific_force'] + shift,
                                   atol=1e-5)
        self.assertGreater(np.abs(shift).max(), 0.01)  # this drive's mean tilt shows

    def test_noise_offset_and_seed(self):
        exact = self.variant('exact', '--twist', 'course', '--accel-noise', 0)
        np.testing.assert_allclose(
            exact['specific_force'],
            variants.make_variant(self.data, self.gt, 'course', accel_noise=0.0)[0][
                'specific_force'], atol=1e-12)
        a = self.variant('a', '--twist', 'course', '--accel-noise', 0.2, '--accel-bias', 0.1,
                         '-0.3', 0.05, '--seed', 7)
        b = self.variant('b', '--twist', 'course', '--accel-noise', 0.2, '--accel-bias', 0.1,
                         '-0.3', 0.05, '--seed', 7)
        c = self.variant('c', '--twist', 'course', '--accel-noise', 0.2, '--accel-bias', 0.1,
                         '-0.3', 0.05, '--seed', 8)
        np.testing.assert_array_equal(a['specific_force'], b['specific_force'])
        self.assertFalse(np.array_equal(a['specific_force'], c['specific_force']))
        error = a['specific_force'] - exact['specific_force']
        np.testing.assert_allclose(error.mean(axis=1), [0.1, -0.3, 0.05], atol=0.06)
        self.assertAlmostEqual(np.std(error - error.mean(axis=1, keepdims=True)), 0.2,
                               delta=0.025)
        scalar = self.variant('scalar', '--twist', 'course', '--accel-noise', 0,
                              '--accel-bias', 0.5)
        np.testing.assert_allclose(scalar['specific_force'] - exact['specific_force'], 0.5,
                                   atol=1e-12)

    def test_everything_else_as_without_it(self):
        for args in (['--twist', 'accurate', '--seed', 3],
                     ['--twist', 'accurate', '--keep-fraction', 0.5, '--seed', 9],
                     ['--twist', 'course', '--keep-fraction', 0.3, '--seed', 2]):
            with self.subTest(args=args):
                name = '_'.join(str(a).strip('-') for a in args)
                plain = self.variant(name, *args)
                accel = self.variant(name + '_accel', *args + ['--accel-noise', 0.3])
                self.assertNotIn('specific_force', plain)
                self.assertEqual(set(accel) - set(plain), {'specific_force'})
                for key in plain:
                    np.testing.assert_array_equal(accel[key], plain[key], err_msg=key)

    def test_groundtruth_gaps_as_the_accurate_twist(self):
        # Frames after the last pose are cut off (specific_force too); a frame without a pose
        # within 0.02 s fails, with either twist, as the accurate twist does.
        with open(self.gt) as f:
            lines = f.readlines()
        short = os.path.join(self.tmp, 'short.tum')
        with open(short, 'w') as f:
            f.writelines(lines[:100])
        out, notes = variants.make_variant(self.data, short, 'course', accel_noise=0.0,
                                           up_world=self.sim['up_world'])
        self.assertEqual(out['specific_force'].shape, (3, 100))
        self.assertEqual(out['features'].shape[2], 100)
        self.assertIn('cut to the 100 frames', notes[0])
        np.testing.assert_allclose(out['specific_force'], self.sim['specific_force'][:, :100],
                                   atol=1e-5)
        gap = os.path.join(self.tmp, 'gap.tum')
        with open(gap, 'w') as f:
            f.writelines(lines[:50] + lines[52:])
        for twist, accel in (('accurate', None), ('course', 0.1), ('accurate', 0.1)):
            with self.subTest(twist=twist, accel=accel):
                with self.assertRaisesRegex(variants.VariantError, 'frame 50 .* no ground-truth'):
                    variants.make_variant(self.data, gap, twist, accel_noise=accel)
        proc = ekf_test_paths.run_script('make_variant.py', self.npz, '--groundtruth', gap,
                                         '--twist', 'course', '--accel-noise', 0.1, '--out',
                                         os.path.join(self.tmp, 'gap.npz'))
        self.assertEqual(proc.returncode, 2)
        self.assertEqual(len(proc.stderr.strip().splitlines()), 1, proc.stderr)
        self.assertIn('no ground-truth pose', proc.stderr)

    def test_usage_errors(self):
        for args in (['--accel-bias', 0.1], ['--accel-noise', 0.1, '--accel-bias', 0.1, 0.2],
                     ['--accel-noise', -1]):
            with self.subTest(args=args):
                out = os.path.join(self.tmp, 'bad.npz')
                proc = ekf_test_paths.run_script('make_variant.py', self.npz, '--groundtruth',
                                                 self.gt, '--twist', 'course', '--out', out,
                                                 *args)
                self.assertEqual(proc.returncode, 2, proc.stderr)
                self.assertNotIn('Traceback', proc.stderr)
                self.assertFalse(os.path.exists(out))


if __name__ == '__main__':
    unittest.main()
