"""Tests of the simulator's accelerometer (options accel_noise, accel_bias; simulate_dataset.py
--accel-noise, --accel-bias): off by default with the drives as before, the specific force of its
definition, gravity's up in the world of the first pose, the noise and the offset."""
import math
import os
import unittest
from unittest import mock

import numpy as np

import ekf_test_paths
from ekf_vislam_tools import simulator
from ekf_vislam_tools.dataset import load_dataset, observed_mask

G = 9.80665
OTHER_KEYS = ('t', 'features', 'linear_velocity', 'rotational_velocity', 'world_T_imu', 'v_true',
              'w_true', 'features_true', 'outlier_mask', 'landmarks', 'gyro_bias')

# simulate(11, frames=60) before the accelerometer existed: (4, 331, 60) features with 3777
# observations, sums and a few values (the new 'accel' stream must leave the drive as it was).
BEFORE_IDS, BEFORE_OBSERVATIONS = 331, 3777
BEFORE_SUMS = {'features': 5724968.909579746, 'linear_velocity': 470.4786099448983,
               'rotational_velocity': 2.0849394276830173}
BEFORE_LAST_POSITION_SUM = 46.61138213306685
BEFORE_V30 = [8.562082171201482, 0.1022032106636508, -0.07518677434272181]
BEFORE_W45 = [0.10288280681050142, -0.07539853320372461, 0.09737607977945681]
BEFORE_FEATURE_5_32 = [304.613544600481, 129.2881442174832, 294.8855036110119, 131.9129461213919]


def specific_force_by_definition(t, world_T_imu, v_true, up_world):
    """f_k = R_k^T (R_k v_k - R_k-1 v_k-1) / (t_k - t_k-1) + g R_k^T up, f_0 = f_1, one frame at a
    time (independent of simulator.specific_force)."""
    f = np.zeros((3, len(t)))
    for k in range(1, len(t)):
        R, R_before = world_T_imu[k, :3, :3], world_T_imu[k - 1, :3, :3]
        change = (R @ v_true[:, k] - R_before @ v_true[:, k - 1]) / (t[k] - t[k - 1])
        f[:, k] = R.T @ change + G * R.T @ up_world
    f[:, 0] = f[:, 1]
    return f


def simulate_recording_profiles(seed, **options):
    """simulate() -> (result, roll(tau), pitch(tau)) with the drive's roll and pitch profiles (the
    2nd and 3rd smooth signals drawn: after the road curvature, before lateral and vertical),
    scaled to radians."""
    made = []
    original = simulator._smooth_signal

    def recording(rng, periods, count=3):
        made.append((periods, original(rng, periods, count)))
        return made[-1][1]
    with mock.patch.object(simulator, '_smooth_signal', recording):
        result = simulator.simulate(seed, **options)
    (roll_periods, (roll, _)), (pitch_periods, (pitch, _)) = made[1], made[2]
    assert (roll_periods, pitch_periods) == ((8.0, 30.0), (10.0, 40.0))
    opts = result['options']
    roll_amp = math.radians(opts['roll_amplitude'])
    pitch_amp = math.radians(opts['pitch_amplitude'])
    return result, lambda tau: roll_amp * roll(tau), lambda tau: pitch_amp * pitch(tau)


class OffByDefaultTest(unittest.TestCase):

    def test_no_accelerometer_and_the_drive_as_before(self):
        r = simulator.simulate(11, frames=60)
        for key in ('specific_force', 'up_world', 'accel_bias'):
            self.assertNotIn(key, r)
        self.assertNotIn('specific_force', simulator.dataset_arrays(r))
        self.assertNotIn('accelerometer', simulator.summary(r))
        observed = observed_mask(r['features'])
        self.assertEqual(r['features'].shape, (4, BEFORE_IDS, 60))
        self.assertEqual(int(observed.sum()), BEFORE_OBSERVATIONS)
        self.assertAlmostEqual(float(r['features'][:, observed].sum()), BEFORE_SUMS['features'],
                               delta=1e-12 * BEFORE_SUMS['features'])
        for key in ('linear_velocity', 'rotational_velocity'):
            self.assertAlmostEqual(float(r[key].sum()), BEFORE_SUMS[key], delta=1e-12 * 500)
        self.assertAlmostEqual(float(r['world_T_imu'][-1, :3, 3].sum()),
                               BEFORE_LAST_POSITION_SUM, delta=1e-9)
        # Within a few of the last bits: numpy's vectorised sin and cos differ by instruction set.
        for value, before in ((r['linear_velocity'][:, 30], BEFORE_V30),
                              (r['rotational_velocity'][:, 45], BEFORE_W45),
                              (r['features'][:, 5, 32], BEFORE_FEATURE_5_32)):
            np.testing.assert_allclose(value, before, rtol=1e-12, atol=0)

    def test_the_accelerometer_leaves_every_other_stream(self):
        plain = simulator.simulate(11, frames=120)
        with_accel = simulator.simulate(11, frames=120, accel_noise=0.2, accel_bias=[0.1, 0, 0])
        for key in OTHER_KEYS:
            np.testing.assert_array_equal(plain[key], with_accel[key], err_msg=key)
        arrays = simulator.dataset_arrays(with_accel)
        plain_arrays = simulator.dataset_arrays(plain)
        self.assertEqual(set(arrays) - set(plain_arrays), {'specific_force'})
        for key in plain_arrays:
            np.testing.assert_array_equal(arrays[key], plain_arrays[key], err_msg=key)

    def test_bad_options(self):
        for options in (dict(accel_noise=-0.1), dict(accel_noise=float('nan')),
                        dict(accel_noise=0.1, accel_bias=[0.1, 0.2]),
                        dict(accel_noise=0.1, accel_bias=float('inf')),
                        dict(accel_bias=0.1)):  # an offset without the accelerometer
            with self.subTest(options=options), self.assertRaises(ValueError):
                simulator.simulate(1, frames=10, **options)


class SpecificForceTest(unittest.TestCase):
    """A hilly drive's noiseless accelerometer against its definition and the physics."""

    @classmethod
    def setUpClass(cls):
        cls.result, roll, pitch = simulate_recording_profiles(
            3, frames=400, roll_amplitude=3.0, pitch_amplitude=6.0, accel_noise=0.0)
        cls.profiles = (roll, pitch)  # not as attributes: functions would become methods

    def test_definition(self):
        r = self.result
        self.assertEqual(r['specific_force'].shape, (3, 400))
        self.assertEqual(r['specific_force'].dtype, np.float64)
        np.testing.assert_array_equal(r['accel_bias'], [0.0, 0.0, 0.0])
        np.testing.assert_array_equal(r['specific_force'][:, 0], r['specific_force'][:, 1])
        expected = specific_force_by_definition(r['t'], r['world_T_imu'], r['v_true'],
                                                r['up_world'])
        np.testing.assert_allclose(r['specific_force'], expected, rtol=0, atol=1e-9)
        magnitude = np.linalg.norm(r['specific_force'], axis=0)
        self.assertTrue(np.all(np.abs(magnitude - G) < 3.0), magnitude)

    def test_up_world_is_the_level_of_the_roll_and_pitch_profiles(self):
        # up_world seen from each pose is the level's up implied by the profiles' roll and pitch
        # at that time (the integrated attitude follows the Euler angles to ~0.001 deg).
        r = self.result
        roll, pitch = self.profiles
        self.assertAlmostEqual(np.linalg.norm(r['up_world']), 1.0, places=12)
        tau = r['t'] - r['t'][0]
        implied = np.array([simulator.level_up_in_body(phi, theta)
                            for phi, theta in zip(roll(tau), pitch(tau))])
        seen = np.einsum('kji,j->ki', r['world_T_imu'][:, :3, :3], r['up_world'])
        angle = np.degrees(np.arccos(np.clip(np.sum(implied * seen, axis=1), -1.0, 1.0)))
        self.assertLess(angle.max(), 0.01)
        # Not trivially so: the world's z is several degrees off the level here.
        self.assertGreater(np.degrees(np.arccos(r['up_world'][2])), 0.5)
        np.testing.assert_allclose(r['up_world'],
                                   simulator.level_up_in_body(roll(np.zeros(1))[0],
                                                              pitch(np.zeros(1))[0]))

    def test_level_drive(self):
        # No roll or pitch: up_world = world z; on the straight, steady stretches the reading is
        # about (0, 0, g); everywhere the forward reading is the change of speed and the lateral
        # one the centripetal acceleration.
        r = simulator.simulate(5, frames=800, roll_amplitude=0.0, pitch_amplitude=0.0,
                               accel_noise=0.0)
        np.testing.assert_allclose(r['up_world'], [0.0, 0.0, 1.0], atol=1e-15)
        t, v, w, f = r['t'], r['v_true'], r['w_true'], r['specific_force']
        change = np.abs(np.diff(v, axis=1)) / np.diff(t)
        steady = np.zeros(t.size, dtype=bool)
        steady[1:] = (np.abs(w[:, 1:]).max(axis=0) < 0.01) & (change.max(axis=0) < 0.05)
        self.assertGreater(steady.sum(), 10)
        np.testing.assert_allclose(f[:, steady], np.tile([[0.0], [0.0], [G]], steady.sum()),
                                   atol=0.1)
        np.testing.assert_allclose(f[0, 1:], np.diff(v[0]) / np.diff(t), atol=0.1)
        np.testing.assert_allclose(f[1], v[0] * w[2], atol=0.1)
        self.assertGreater(np.abs(f[1]).max(), 1.0)   # there are turns

    def test_noise_and_offset(self):
        clean = simulator.simulate(9, frames=800, accel_noise=0.0)
        noisy = simulator.simulate(9, frames=800, accel_noise=0.3, accel_bias=[0.1, -0.2, 0.05])
        np.testing.assert_array_equal(noisy['accel_bias'], [0.1, -0.2, 0.05])
        np.testing.assert_array_equal(noisy['up_world'], clean['up_world'])
        error = noisy['specific_force'] - clean['specific_force']
        np.testing.assert_allclose(error.mean(axis=1), [0.1, -0.2, 0.05], atol=0.04)
        np.testing.assert_allclose(error.std(axis=1), 0.3, rtol=0.1)
        self.assertLess(abs(np.corrcoef(error[0, :-1], error[0, 1:])[0, 1]), 0.1)  # white
        scalar = simulator.simulate(9, frames=800, accel_noise=0.0, accel_bias=0.5)
        np.testing.assert_allclose(scalar['specific_force'] - clean['specific_force'], 0.5,
                                   atol=1e-12)
        self.assertIn('accelerometer noise 0.3 m/s^2', simulator.summary(noisy))


class SimulateDatasetAccelerometerTest(unittest.TestCase):
    """simulate_dataset.py --accel-noise / --accel-bias."""

    @classmethod
    def setUpClass(cls):
        cls.tmp = ekf_test_paths.make_temp_dir()
        cls.addClassCleanup(ekf_test_paths.remove_dir, cls.tmp)

    def test_npz_field(self):
        prefix = os.path.join(self.tmp, 'accel')
        proc = ekf_test_paths.run_script('simulate_dataset.py', '--seed', 3, '--frames', 50,
                                         '--accel-noise', 0.1, '--accel-bias', 0.2, '-0.1', 0.0,
                                         '--out', prefix)
        self.assertEqual(proc.returncode, 0, proc.stderr)
        self.assertIn('accelerometer', proc.stdout)
        expected = simulator.simulate(3, frames=50, accel_noise=0.1, accel_bias=[0.2, -0.1, 0.0])
        with np.load(prefix + '.npz', allow_pickle=False) as npz:
            self.assertIn('specific_force', npz.files)
            self.assertEqual(npz['specific_force'].shape, (3, 50))
            self.assertEqual(npz['specific_force'].dtype, np.float64)
            np.testing.assert_array_equal(npz['specific_force'], expected['specific_force'])
        dataset = load_dataset(prefix + '.npz')
        np.testing.assert_array_equal(dataset.specific_force, expected['specific_force'])
        plain = os.path.join(self.tmp, 'plain')
        proc = ekf_test_paths.run_script('simulate_dataset.py', '--seed', 3, '--frames', 50,
                                         '--out', plain)
        self.assertEqual(proc.returncode, 0, proc.stderr)
        with np.load(plain + '.npz', allow_pickle=False) as npz:
            self.assertNotIn('specific_force', npz.files)
        self.assertIsNone(load_dataset(plain + '.npz').specific_force)

    def test_usage_errors(self):
        for args in (['--accel-bias', 0.1], ['--accel-noise', 0.1, '--accel-bias', 0.1, 0.2],
                     ['--accel-noise', -1]):
            with self.subTest(args=args):
                proc = ekf_test_paths.run_script('simulate_dataset.py', '--frames', 10, '--out',
                                                 os.path.join(self.tmp, 'bad'), *args)
                self.assertEqual(proc.returncode, 2, proc.stderr)
                self.assertNotIn('Traceback', proc.stderr)
                self.assertFalse(os.path.exists(os.path.join(self.tmp, 'bad.npz')))


if __name__ == '__main__':
    unittest.main()
