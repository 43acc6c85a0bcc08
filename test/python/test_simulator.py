"""Tests of the simulator (ekf_vislam_tools.simulator) and its CLI scripts/simulate_dataset.py."""
import csv
import os
import unittest

import numpy as np

import ekf_test_paths
from ekf_vislam_tools import se3, simulator, trajectory
from ekf_vislam_tools.dataset import load_dataset, observed_mask

DATASET_KEYS = ('t', 'features', 'linear_velocity', 'rotational_velocity', 'K', 'cam_T_imu',
                'image_size')
TRUTH_KEYS = ('world_T_imu', 'v_true', 'w_true', 'features_true', 'outlier_mask', 'landmarks',
              'gyro_bias')


def integrate(t, v, w):
    """world_T_imu from a twist sequence, convention T(k+1) = T(k) exp(tau u(k+1))."""
    poses = [np.eye(4)]
    for k in range(len(t) - 1):
        poses.append(poses[-1] @ se3.twist_exp(v[:, k + 1], w[:, k + 1], t[k + 1] - t[k]))
    return np.array(poses)


def gross_errors(result, threshold_px=10.0):
    """(M,T) True where an observation is off its noiseless value by more than threshold_px."""
    observed = observed_mask(result['features'])
    error = np.abs(result['features'] - result['features_true']).max(axis=0)
    return observed & (error > threshold_px)


def lag_one_correlation(result):
    """Correlation of the u_left error of a track between consecutive frames (inliers only)."""
    error = result['features'][0] - result['features_true'][0]
    good = observed_mask(result['features']) & ~result['outlier_mask']
    both = good[:, :-1] & good[:, 1:]
    return float(np.corrcoef(error[:, :-1][both], error[:, 1:][both])[0, 1])


class SimulatorTest(unittest.TestCase):
    """The default 800-frame drive: statistics, geometry, noise."""

    @classmethod
    def setUpClass(cls):
        cls.result = simulator.simulate(7)
        cls.stats = simulator.statistics(cls.result['features'])
        cls.observed = observed_mask(cls.result['features'])

    def test_defaults_match_the_real_data_shape(self):
        r = self.result
        self.assertEqual(r['features'].shape[0], 4)
        self.assertEqual(r['features'].shape[2], 800)
        self.assertEqual(r['linear_velocity'].shape, (3, 800))
        self.assertEqual(r['rotational_velocity'].shape, (3, 800))
        np.testing.assert_array_equal(r['K'], simulator.KITTI_K)
        self.assertAlmostEqual(r['b'], 0.5371506532679237)
        np.testing.assert_array_equal(r['image_size'], [1241, 376])
        np.testing.assert_allclose(r['cam_T_imu'][:3, :3],
                                   [[0, -1, 0], [0, 0, -1], [1, 0, 0]])
        np.testing.assert_allclose(r['cam_T_imu'][:3, 3], [-0.3164, 0.7341, -1.1380])

    def test_observations_per_frame(self):
        per_frame = self.stats['obs_per_frame']
        self.assertTrue(55 <= per_frame.mean() <= 90, per_frame.mean())
        self.assertGreater(per_frame.min(), 15)

    def test_tracks(self):
        lengths = self.stats['track_lengths']
        self.assertTrue(np.all(lengths >= 1), 'an id that is never observed')
        self.assertTrue(8 <= lengths.mean() <= 30, lengths.mean())
        self.assertTrue(self.stats['contiguous'], 'an id seen in more than one run of frames')

    def test_outliers(self):
        r = self.result
        rate = r['options']['outlier_rate']
        gross = gross_errors(r)
        fraction = gross.sum() / self.observed.sum()
        self.assertAlmostEqual(fraction, rate, delta=0.3 * rate)
        # Every gross error is a declared outlier (pixel noise alone never reaches 10 px).
        self.assertFalse(np.any(gross & ~r['outlier_mask']))
        disparity = r['features'][0] - r['features'][2]
        negative = self.observed & (disparity < 0) & r['outlier_mask']
        self.assertGreater(negative.sum(), 0.2 * r['outlier_mask'].sum())

    def test_pixel_noise(self):
        r = self.result
        inlier = self.observed & ~r['outlier_mask']
        residual = (r['features'] - r['features_true'])[:, inlier]
        self.assertAlmostEqual(residual.std(), 1.0, delta=0.05)
        self.assertAlmostEqual(residual.mean(), 0.0, delta=0.05)

    def test_pixel_noise_is_white_by_default(self):
        self.assertAlmostEqual(lag_one_correlation(self.result), 0.0, delta=0.03)

    def test_drifting_tracks(self):
        r = simulator.simulate(7, frames=300, pixel_correlation=0.85, outlier_rate=0.0)
        inlier = observed_mask(r['features'])
        residual = (r['features'] - r['features_true'])[:, inlier]
        self.assertAlmostEqual(residual.std(), 1.0, delta=0.1)
        self.assertAlmostEqual(lag_one_correlation(r), 0.85, delta=0.03)

    def test_systematic_drift_grows_with_the_track_age(self):
        r = simulator.simulate(7, frames=200, pixel_noise=0.0, outlier_rate=0.0,
                               drift_expansion=0.25, drift_v=-0.05)
        observed = observed_mask(r['features'])
        error = r['features'] - r['features_true']
        fx, cx = simulator.KITTI_K[0, 0], simulator.KITTI_K[0, 2]
        for track in np.flatnonzero(observed.sum(axis=1) >= 5)[:50]:
            frames = np.flatnonzero(observed[track])
            age = frames - frames[0]
            true = r['features_true'][:, track, frames]
            np.testing.assert_allclose(error[0, track, frames], age * 0.25 * (true[0] - cx) / fx,
                                       atol=1e-9)
            np.testing.assert_allclose(error[2, track, frames], age * 0.25 * (true[2] - cx) / fx,
                                       atol=1e-9)
            np.testing.assert_allclose(error[[1, 3]][:, track, frames],
                                       np.vstack([age * -0.05] * 2), atol=1e-9)
        # Outward in u, so the disparity grows with the age too.
        disparity_error = error[0] - error[2]
        self.assertGreater(disparity_error[observed].mean(), 0.0)
        # Off by default: the default drive's arrays are those without the options.
        plain = simulator.simulate(7, frames=50)
        zero = simulator.simulate(7, frames=50, drift_expansion=0.0, drift_v=0.0)
        np.testing.assert_array_equal(plain['features'], zero['features'])

    def test_a_disparity_offset_moves_every_right_column(self):
        plain = simulator.simulate(7, frames=50)
        offset = simulator.simulate(7, frames=50, disparity_offset=0.8)
        inlier = observed_mask(plain['features']) & ~plain['outlier_mask']
        moved = plain['features'][2][inlier] - offset['features'][2][inlier]
        np.testing.assert_allclose(moved, 0.8, atol=1e-9)  # outliers are made from it anew
        np.testing.assert_array_equal(plain['features'][[0, 1, 3]], offset['features'][[0, 1, 3]])
        np.testing.assert_array_equal(plain['features_true'], offset['features_true'])

    def test_traffic_adds_moving_tracks_and_leaves_the_scene_alone(self):
        plain = simulator.simulate(7, frames=200)
        busy = simulator.simulate(7, frames=200, vehicles_ahead=1, oncoming_per_minute=6.0)
        static = plain['features'].shape[1]
        np.testing.assert_array_equal(busy['features'][:, :static], plain['features'])
        cars = np.arange(static, busy['features'].shape[1])
        self.assertGreater(len(cars), 24)
        np.testing.assert_array_equal(busy['point_of_id'][cars], -1)
        seen = observed_mask(busy['features_true'])[cars]  # (cars, T)
        self.assertTrue(seen.any(axis=1).all())  # every car id is observed
        self.assertGreater(seen.any(axis=0).mean(), 0.8)  # a car in sight most of the drive
        # A car's corner is not where it was first seen: reprojected from there it misses by
        # pixels within a second (a static point misses by nothing).
        misses = []
        for i in np.flatnonzero(seen.sum(axis=1) >= 10):
            frames = np.flatnonzero(seen[i])
            k = frames[9]
            z, _ = simulator.project(busy['landmarks'][cars[i]][None], busy['world_T_imu'][k])
            misses.append(np.abs(z[0] - busy['features_true'][:, cars[i], k]).max())
        self.assertGreater(len(misses), 24)
        self.assertGreater(np.median(misses), 2.0)
        with self.assertRaises(ValueError):
            simulator.simulate(7, frames=10, vehicles_ahead=-1)

    def test_few_observations_per_frame(self):
        # Below the 20 per frame the simulator once floored the target at.
        for target in (2, 5):
            stats = simulator.statistics(simulator.simulate(7, frames=300,
                                                            target_obs=target)['features'])
            self.assertAlmostEqual(stats['obs_per_frame'].mean(), target, delta=0.3 * target)

    def test_noiseless_observations_are_observable(self):
        z = self.result['features_true'][:, self.observed]
        width, height = self.result['image_size']
        self.assertTrue(np.all(z[0] - z[2] > 0.5))
        self.assertTrue(np.all((z[[0, 2]] >= 0) & (z[[0, 2]] <= width - 1)))
        self.assertTrue(np.all((z[[1, 3]] >= 0) & (z[[1, 3]] <= height - 1)))
        np.testing.assert_allclose(z[1], z[3])

    def test_twist_noise_and_gyro_offset(self):
        r = self.result
        v_error = r['linear_velocity'] - r['v_true']
        w_error = r['rotational_velocity'] - r['w_true']
        np.testing.assert_allclose(v_error.std(axis=1), 0.5, rtol=0.1)
        np.testing.assert_allclose(w_error.std(axis=1), 0.05, rtol=0.1)
        magnitude = np.abs(r['gyro_bias'])
        self.assertTrue(np.all((magnitude >= 0.005) & (magnitude <= 0.01)), r['gyro_bias'])
        np.testing.assert_allclose(w_error.mean(axis=1), r['gyro_bias'], atol=0.006)

    def test_groundtruth_is_the_integrated_true_twist(self):
        r = self.result
        np.testing.assert_array_equal(r['v_true'][:, 0], r['v_true'][:, 1])
        np.testing.assert_array_equal(r['w_true'][:, 0], r['w_true'][:, 1])
        np.testing.assert_allclose(r['world_T_imu'][0], np.eye(4))
        np.testing.assert_allclose(integrate(r['t'], r['v_true'], r['w_true']), r['world_T_imu'],
                                   atol=1e-9)

    def test_drive_is_car_like(self):
        r = self.result
        dt = np.diff(r['t'])
        self.assertTrue(np.all(np.abs(dt - 0.1) <= 0.001 + 1e-9))
        self.assertTrue(np.all((r['v_true'][0] >= 5) & (r['v_true'][0] <= 10)))
        self.assertTrue(300 <= r['path_length'] <= 1000, r['path_length'])
        yaw_rate = np.abs(r['w_true'][2])
        self.assertTrue(0.15 <= yaw_rate.max() <= 0.32, yaw_rate.max())
        self.assertGreater(np.mean(yaw_rate < 0.03), 0.3, 'no straight stretches')
        turning = np.diff((yaw_rate > 0.1).astype(int)) == 1
        self.assertGreaterEqual(turning.sum(), 3, 'fewer than three turns')
        # Small roll/pitch: gravity direction (world z in the body) stays near body z.
        up_in_body = r['world_T_imu'][:, 2, :3]
        tilt = np.degrees(np.arccos(np.clip(up_in_body[:, 2], -1, 1)))
        self.assertLess(tilt.max(), 6.0)
        self.assertLess(np.abs(r['v_true'][1:]).max(), 0.2)

    def test_landmarks_project_to_the_noiseless_observations(self):
        r = self.result
        ids, frames = np.nonzero(self.observed)
        pick = np.random.default_rng(0).choice(ids.size, 2000, replace=False)
        for j, k in zip(ids[pick], frames[pick]):
            z, depth = simulator.project(r['landmarks'][j][None], r['world_T_imu'][k],
                                         r['cam_T_imu'], r['K'], r['b'])
            np.testing.assert_allclose(z[0], r['features_true'][:, j, k], atol=1e-6)
            self.assertTrue(2.0 <= depth[0] <= 60.0)


class DeterminismTest(unittest.TestCase):

    def test_same_seed_same_arrays(self):
        a = simulator.simulate(11, frames=120)
        b = simulator.simulate(11, frames=120)
        for key in DATASET_KEYS + TRUTH_KEYS:
            np.testing.assert_array_equal(a[key], b[key], err_msg=key)

    def test_different_seed_different_arrays(self):
        a = simulator.simulate(11, frames=120)
        b = simulator.simulate(12, frames=120)
        self.assertFalse(np.array_equal(a['linear_velocity'], b['linear_velocity']))
        self.assertFalse(np.allclose(a['world_T_imu'][-1], b['world_T_imu'][-1]))
        same_features = (a['features'].shape == b['features'].shape
                         and np.array_equal(a['features'], b['features']))
        self.assertFalse(same_features)

    def test_noise_options_leave_the_geometry(self):
        noisy = simulator.simulate(11, frames=120)
        clean = simulator.simulate(11, frames=120, pixel_noise=0.0, outlier_rate=0.0,
                                   velocity_noise=0.0, gyro_noise=0.0, gyro_bias=0.0)
        np.testing.assert_array_equal(noisy['world_T_imu'], clean['world_T_imu'])
        np.testing.assert_array_equal(noisy['features_true'], clean['features_true'])
        np.testing.assert_array_equal(clean['features'], clean['features_true'])
        np.testing.assert_array_equal(clean['linear_velocity'], clean['v_true'])
        np.testing.assert_array_equal(clean['rotational_velocity'], clean['w_true'])

    def test_length_option(self):
        r = simulator.simulate(4, length_m=150.0)
        self.assertAlmostEqual(r['path_length'], 150.0, delta=1.5)

    def test_hills(self):
        # A hilly drive: the vehicle's tilt against the first pose's level reaches several
        # degrees, and the ground truth stays the integrated true twist.
        flat = simulator.simulate(7, frames=300)
        hilly = simulator.simulate(7, frames=300, roll_amplitude=3.0, pitch_amplitude=6.0)

        def tilt_deg(result):
            up = result['world_T_imu'][:, :3, 2]
            return np.degrees(np.arccos(np.clip(up[:, 2], -1, 1)))
        self.assertLess(tilt_deg(flat).max(), 5.0)
        self.assertGreater(tilt_deg(hilly).max(), 6.0)
        self.assertLess(tilt_deg(hilly).max(), 20.0)
        np.testing.assert_allclose(integrate(hilly['t'], hilly['v_true'], hilly['w_true']),
                                   hilly['world_T_imu'], atol=1e-9)

    def test_stops(self):
        # A 20-s stop from 15 s: the vehicle slows over 3 s, stands still (no motion, no turn),
        # its wheel odometry reads exactly 0 while the gyro keeps its noise, and drives on; the
        # drive before the stop is the one without it.
        r = simulator.simulate(7, frames=500, stops=((15.0, 20.0),))
        plain = simulator.simulate(7, frames=500)
        tau = r['t'] - r['t'][0]
        rest = (tau > 15.1) & (tau < 34.9)
        speed = np.linalg.norm(r['v_true'], axis=0)
        self.assertTrue(np.all(speed[rest] == 0.0))
        self.assertTrue(np.all(r['w_true'][:, rest] == 0.0))
        self.assertTrue(np.all(r['linear_velocity'][:, rest] == 0.0))
        self.assertGreater(np.std(r['rotational_velocity'][:, rest]), 0.03)
        self.assertGreater(speed[tau > 40.0].min(), 1.0)
        early = tau < 11.9
        np.testing.assert_array_equal(r['v_true'][:, early], plain['v_true'][:, early])
        np.testing.assert_allclose(integrate(r['t'], r['v_true'], r['w_true']), r['world_T_imu'],
                                   atol=1e-9)
        # At rest a track keeps its pixel error (the same view gives the same track) but for the
        # sensor's jitter, rest_pixel_jitter (0.02 px); the error itself stays pixel-sized.
        error = r['features'] - r['features_true']
        k = np.flatnonzero(rest)[5]
        both = ((r['features'][0, :, k] >= 0) & (r['features'][0, :, k - 1] >= 0) &
                ~r['outlier_mask'][:, k] & ~r['outlier_mask'][:, k - 1])
        self.assertGreater(both.sum(), 20)
        step = error[:, both, k] - error[:, both, k - 1]
        self.assertLess(np.abs(step).max(), 0.15)
        self.assertGreater(np.abs(step).max(), 0.01)
        self.assertGreater(np.abs(error[:, both, k]).mean(), 0.5)
        for bad in (((1.0, 5.0),), ((10.0, 0.0),), ((10.0,),)):
            with self.assertRaises(ValueError):
                simulator.simulate(1, frames=200, stops=bad)

    def test_bad_options(self):
        with self.assertRaises(ValueError):
            simulator.simulate(1, pitch_amplitude=-1.0)
        with self.assertRaises(ValueError):
            simulator.simulate(1, rest_pixel_jitter=-0.1)
        with self.assertRaises(ValueError):
            simulator.simulate(1, outlier_rate=1.5)
        with self.assertRaises(ValueError):
            simulator.simulate(1, frames=0)
        with self.assertRaises(TypeError):
            simulator.simulate(1, no_such_option=3)


class SimulateDatasetScriptTest(unittest.TestCase):
    """The CLI: files, their formats and agreement with the in-process simulation."""

    FRAMES = 150

    @classmethod
    def setUpClass(cls):
        cls.tmp = ekf_test_paths.make_temp_dir()
        cls.addClassCleanup(ekf_test_paths.remove_dir, cls.tmp)
        cls.prefix = os.path.join(cls.tmp, 'sim')
        cls.proc = ekf_test_paths.run_script('simulate_dataset.py', '--seed', 3, '--frames',
                                             cls.FRAMES, '--out', cls.prefix)
        cls.expected = simulator.simulate(3, frames=cls.FRAMES)

    def test_exit_and_summary(self):
        self.assertEqual(self.proc.returncode, 0, self.proc.stderr)
        self.assertEqual(self.proc.stderr, '')
        lines = self.proc.stdout.strip().splitlines()
        self.assertEqual(len(lines), 1)
        self.assertIn('%d frames' % self.FRAMES, lines[0])
        self.assertIn('observations/frame', lines[0])
        self.assertIn('mean track', lines[0])

    def test_npz_layout(self):
        with np.load(self.prefix + '.npz', allow_pickle=False) as npz:
            self.assertEqual(set(npz.files), {
                'time_stamps', 'features', 'linear_velocity', 'rotational_velocity', 'K', 'b',
                'cam_T_imu', 'cam_T_imu_translation_correct', 'image_size'})
            self.assertEqual(npz['time_stamps'].shape, (1, self.FRAMES))
            self.assertTrue(bool(npz['cam_T_imu_translation_correct']))
            np.testing.assert_array_equal(npz['image_size'], [1241, 376])
            np.testing.assert_array_equal(npz['time_stamps'][0], self.expected['t'])
            np.testing.assert_array_equal(npz['features'], self.expected['features'])
            np.testing.assert_array_equal(npz['rotational_velocity'],
                                          self.expected['rotational_velocity'])
            np.testing.assert_array_equal(npz['cam_T_imu'], simulator.KITTI_CAM_T_IMU)

    def test_npz_loads_without_extrinsic_fix(self):
        dataset = load_dataset(self.prefix + '.npz')
        self.assertFalse(dataset.extrinsic_fixed)
        np.testing.assert_array_equal(dataset.cam_T_imu, simulator.KITTI_CAM_T_IMU)
        self.assertEqual(dataset.image_size, (1241, 376))

    def test_groundtruth_file(self):
        t, world_T_imu = trajectory.read_tum(self.prefix + '_groundtruth.tum')
        np.testing.assert_array_equal(t, self.expected['t'])
        np.testing.assert_allclose(world_T_imu[0], np.eye(4), atol=1e-12)
        np.testing.assert_allclose(world_T_imu, self.expected['world_T_imu'], atol=1e-6)

    def test_landmarks_file(self):
        with open(self.prefix + '_landmarks.csv') as f:
            rows = list(csv.reader(f))
        self.assertEqual(rows[0], ['id', 'x', 'y', 'z'])
        ids = np.array([int(row[0]) for row in rows[1:]])
        np.testing.assert_array_equal(ids, np.arange(self.expected['features'].shape[1]))
        xyz = np.array([[float(x) for x in row[1:]] for row in rows[1:]])
        np.testing.assert_allclose(xyz, self.expected['landmarks'], atol=1e-8)

    def test_noiseless_files_reproject(self):
        """landmarks.csv seen through the TUM poses gives the npz observations exactly."""
        prefix = os.path.join(self.tmp, 'clean')
        proc = ekf_test_paths.run_script('simulate_dataset.py', '--seed', 5, '--frames', 60,
                                         '--pixel-noise', 0, '--outlier-rate', 0, '--out', prefix)
        self.assertEqual(proc.returncode, 0, proc.stderr)
        landmarks = np.loadtxt(prefix + '_landmarks.csv', delimiter=',', skiprows=1, ndmin=2)
        _, world_T_imu = trajectory.read_tum(prefix + '_groundtruth.tum')
        dataset = load_dataset(prefix + '.npz')
        observed = dataset.observed()
        self.assertGreater(observed.sum(), 1000)
        for k in range(dataset.num_frames):
            ids = np.flatnonzero(observed[:, k])
            z, _ = simulator.project(landmarks[ids, 1:], world_T_imu[k], dataset.cam_T_imu,
                                     dataset.K, dataset.b)
            np.testing.assert_allclose(z.T, dataset.features[:, ids, k], atol=1e-3)

    def test_same_seed_same_files(self):
        prefix = os.path.join(self.tmp, 'again')
        proc = ekf_test_paths.run_script('simulate_dataset.py', '--seed', 3, '--frames',
                                         self.FRAMES, '--out', prefix + '.npz')
        self.assertEqual(proc.returncode, 0, proc.stderr)
        with np.load(self.prefix + '.npz') as a, np.load(prefix + '.npz') as b:
            for key in a.files:
                np.testing.assert_array_equal(a[key], b[key], err_msg=key)
        with open(self.prefix + '_groundtruth.tum') as a, open(prefix + '_groundtruth.tum') as b:
            self.assertEqual(a.read(), b.read())

    def test_length_m(self):
        prefix = os.path.join(self.tmp, 'length')
        proc = ekf_test_paths.run_script('simulate_dataset.py', '--seed', 2, '--length-m', 120,
                                         '--out', prefix)
        self.assertEqual(proc.returncode, 0, proc.stderr)
        _, world_T_imu = trajectory.read_tum(prefix + '_groundtruth.tum')
        steps = np.linalg.norm(np.diff(world_T_imu[:, :3, 3], axis=0), axis=1)
        self.assertAlmostEqual(steps.sum(), 120.0, delta=1.5)

    def test_bad_option_is_one_line(self):
        proc = ekf_test_paths.run_script('simulate_dataset.py', '--seed', 1, '--outlier-rate',
                                         1.5, '--out', os.path.join(self.tmp, 'bad'))
        self.assertEqual(proc.returncode, 2)
        self.assertEqual(len(proc.stderr.strip().splitlines()), 1, proc.stderr)
        self.assertIn('outlier_rate', proc.stderr)
        self.assertNotIn('Traceback', proc.stderr)
        self.assertFalse(os.path.exists(os.path.join(self.tmp, 'bad.npz')))


if __name__ == '__main__':
    unittest.main()
