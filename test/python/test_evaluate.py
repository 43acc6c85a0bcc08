#!/usr/bin/python3
"""Tests of ekf_vislam_tools.metrics and scripts/evaluate.py (unittest, a few seconds).

Run: cd test/python && /usr/bin/python3 -m unittest -v test_evaluate
"""
import importlib.util
import json
import os
import shutil
import subprocess
import sys
import tempfile
import unittest

import numpy as np

REPO = os.path.abspath(os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..'))
SRC = os.path.join(REPO, 'src')
if SRC not in sys.path:
    sys.path.insert(0, SRC)

from ekf_vislam_tools import metrics, se3, trajectory  # noqa: E402

EVALUATE = os.path.join(REPO, 'scripts', 'evaluate.py')


def random_rigid(rng, translation_scale=20.0):
    """A random 4x4 rigid transform."""
    return se3.se3_exp(np.concatenate([rng.normal(0, translation_scale, 3), rng.normal(0, 1.0, 3)]))


def curvy_trajectory(n, step_m=1.0, dt=0.1, t0=1000.0, seed=0):
    """(t[n], world_T_imu[n]) of a car-like path: steps of step_m, weaving yaw, slight pitch.

    The heading oscillates by about +-0.25 rad, so the path is curvy while segments of 100-800 m
    stay nearly as long as their chord (needed for the 2 % scale test).
    """
    rng = np.random.default_rng(seed)
    phase = rng.uniform(0, 2 * np.pi)
    T = np.empty((n, 4, 4))
    T[0] = random_rigid(rng, 5.0)
    for k in range(1, n):
        yaw_rate = 0.008 * np.cos(2 * np.pi * k / 200.0 + phase)  # rad per step
        pitch_rate = 0.001 * np.sin(2 * np.pi * k / 330.0)
        T[k] = T[k - 1] @ se3.se3_exp([step_m, 0.0, 0.0, 0.0, pitch_rate, yaw_rate])
    return t0 + dt * np.arange(n), T


def straight_trajectory(n, step_m=1.0, dt=0.1, t0=0.0):
    T = np.tile(np.eye(4), (n, 1, 1))
    T[:, 0, 3] = step_m * np.arange(n)
    return t0 + dt * np.arange(n), T


def transform_poses(A, T):
    """A @ T[i] for each pose."""
    return np.einsum('ij,njk->nik', A, T)


class UmeyamaTest(unittest.TestCase):
    def test_recovers_random_rigid_transform(self):
        rng = np.random.default_rng(1)
        src = rng.normal(0, 50, (200, 3))
        A = random_rigid(rng)
        dst = src @ A[:3, :3].T + A[:3, 3]
        R, t, s = metrics.umeyama_alignment(src, dst)
        np.testing.assert_allclose(R, A[:3, :3], atol=1e-9)
        np.testing.assert_allclose(t, A[:3, 3], atol=1e-9)
        self.assertEqual(s, 1.0)

    def test_recovers_scale_when_asked(self):
        rng = np.random.default_rng(2)
        src = rng.normal(0, 10, (50, 3))
        A = random_rigid(rng)
        dst = 1.7 * src @ A[:3, :3].T + A[:3, 3]
        R, t, s = metrics.umeyama_alignment(src, dst, with_scale=True)
        self.assertAlmostEqual(s, 1.7, delta=1e-9)
        np.testing.assert_allclose(R, A[:3, :3], atol=1e-9)
        np.testing.assert_allclose(t, A[:3, 3], atol=1e-9)

    def test_never_returns_a_reflection(self):
        rng = np.random.default_rng(3)
        src = rng.normal(0, 10, (30, 3))
        dst = src * np.array([1.0, 1.0, -1.0])  # a mirror image
        R, _, _ = metrics.umeyama_alignment(src, dst)
        self.assertAlmostEqual(np.linalg.det(R), 1.0, delta=1e-12)

    def test_rejects_too_few_points(self):
        with self.assertRaises(metrics.EvaluationError):
            metrics.umeyama_alignment(np.zeros((2, 3)), np.zeros((2, 3)))


class AssociationTest(unittest.TestCase):
    def test_offsets_and_missing_poses(self):
        t_gt = 100.0 + 0.1 * np.arange(50)
        keep = np.array([k for k in range(50) if k % 7 != 3])  # missing estimate poses
        t_est = t_gt[keep] + 0.015  # constant time offset, within max_dt
        t_est[5] += 0.03  # now 0.045 s away: unmatched
        idx_est, idx_gt = metrics.associate(t_est, t_gt, max_dt=0.02)
        expected_est = np.array([i for i in range(keep.size) if i != 5])
        np.testing.assert_array_equal(idx_est, expected_est)
        np.testing.assert_array_equal(idx_gt, keep[expected_est])

    def test_nearest_and_one_to_one(self):
        t_gt = np.array([0.0, 1.0, 2.0, 3.0])
        t_est = np.array([0.9, 1.004, 2.6, 2.99, 10.0])
        idx_est, idx_gt = metrics.associate(t_est, t_gt, max_dt=0.15)
        # 0.9 and 1.004 both pick stamp 1.0: only the closer (1.004) is kept; 2.6 matches nothing.
        np.testing.assert_array_equal(idx_est, [1, 3])
        np.testing.assert_array_equal(idx_gt, [1, 3])

    def test_unsorted_ground_truth(self):
        t_gt = np.array([3.0, 1.0, 2.0, 0.0])
        idx_est, idx_gt = metrics.associate(np.array([0.0, 1.0, 2.0, 3.0]), t_gt, max_dt=0.01)
        np.testing.assert_array_equal(idx_est, [0, 1, 2, 3])
        np.testing.assert_array_equal(idx_gt, [3, 1, 2, 0])

    def test_too_few_matches_is_an_error(self):
        t, T = straight_trajectory(20)
        with self.assertRaisesRegex(metrics.EvaluationError, 'only 0 of 20'):
            metrics.evaluate_trajectory(t + 5.0, T, t, T)


class TrajectoryMetricsTest(unittest.TestCase):
    def test_rigidly_transformed_copy_has_zero_error(self):
        t, gtworld_T_imu = curvy_trajectory(400)
        estworld_T_gtworld = random_rigid(np.random.default_rng(4), 100.0)
        estworld_T_imu = transform_poses(estworld_T_gtworld, gtworld_T_imu)
        result = metrics.evaluate_trajectory(t, estworld_T_imu, t, gtworld_T_imu)
        self.assertLess(result['ate_rmse_m'], 1e-9)
        self.assertLess(result['ate_max_m'], 1e-9)
        self.assertLess(result['rotation_rmse_deg'], 1e-9)
        self.assertLess(result['final_position_error_m'], 1e-9)
        self.assertLess(result['rpe_percent'], 1e-9)
        self.assertEqual(result['matched_poses'], 400)
        self.assertAlmostEqual(result['path_length_m'], 399.0, delta=0.01)  # chords of 1 m arcs
        np.testing.assert_allclose(result['gtworld_T_estworld'], se3.inverse(estworld_T_gtworld),
                                   atol=1e-9)

    def test_ate_with_known_noise(self):
        rng = np.random.default_rng(5)
        t, gtworld_T_imu = curvy_trajectory(3000)
        noise = rng.normal(0, 0.2, (3000, 3))
        noisy = gtworld_T_imu.copy()
        noisy[:, :3, 3] += noise
        expected_rmse = np.sqrt(np.mean(np.sum(noise ** 2, axis=1)))
        # Without alignment the ATE is exactly the RMSE of the added noise...
        unaligned = metrics.ate(gtworld_T_imu[:, :3, 3], noisy[:, :3, 3], align=False)
        self.assertAlmostEqual(unaligned['rmse'], expected_rmse, delta=1e-12)
        # ...and the rigid alignment (6 dof over 3000 poses) can only reduce it very slightly,
        # also when the estimate lives in another world frame.
        estworld_T_imu = transform_poses(random_rigid(rng, 30.0), noisy)
        result = metrics.evaluate_trajectory(t, estworld_T_imu, t, gtworld_T_imu)
        self.assertLessEqual(result['ate_rmse_m'], expected_rmse + 1e-12)
        self.assertAlmostEqual(result['ate_rmse_m'], expected_rmse, delta=0.005 * expected_rmse)
        errors = np.linalg.norm(noise, axis=1)
        self.assertAlmostEqual(result['ate_median_m'], np.median(errors), delta=0.01)
        self.assertAlmostEqual(result['ate_mean_m'], np.mean(errors), delta=0.005)

    def test_rotation_rmse_with_known_angles(self):
        rng = np.random.default_rng(6)
        t, gtworld_T_imu = curvy_trajectory(300)
        angle = np.radians(2.0)
        est = gtworld_T_imu.copy()
        for k in range(len(est)):  # rotate each body frame by 2 deg about a random axis
            axis = rng.normal(size=3)
            est[k, :3, :3] = est[k, :3, :3] @ se3.so3_exp(angle * axis / np.linalg.norm(axis))
        result = metrics.evaluate_trajectory(t, est, t, gtworld_T_imu)
        self.assertLess(result['ate_rmse_m'], 1e-9)
        # The orientation fit takes up the mean of 300 random-axis errors (about 0.1 degree).
        self.assertAlmostEqual(result['rotation_rmse_deg'], 2.0, delta=0.01)

    def test_rotation_rmse_of_a_straight_path_does_not_take_the_position_fits_roll(self):
        # Exact orientations, positions off by 1 cm: the position fit's rotation about the
        # path's axis is then set by the noise, and would show as a rotation error.
        rng = np.random.default_rng(8)
        t, gtworld_T_imu = straight_trajectory(60)
        est = gtworld_T_imu.copy()
        est[:, :3, 3] += rng.normal(0, 0.01, (60, 3))
        est = transform_poses(random_rigid(rng), est)
        matched = metrics.match_and_align(t, est, t, gtworld_T_imu)
        by_positions = metrics.rotation_rmse(matched.gtworld_T_imu_gt[:, :3, :3],
                                             matched.gtworld_T_imu_est[:, :3, :3])
        self.assertGreater(by_positions, 1.0)
        result = metrics.trajectory_metrics(matched)
        self.assertLess(result['rotation_rmse_deg'], 1e-6)
        self.assertLess(result['ate_rmse_m'], 0.02)

    def test_rpe_of_translation_scaled_by_1_02_is_2_percent(self):
        t, gtworld_T_imu = curvy_trajectory(1500)  # about 1.5 km
        est = transform_poses(random_rigid(np.random.default_rng(7)), gtworld_T_imu)
        est[:, :3, 3] *= 1.02
        rpe = metrics.rpe_kitti(gtworld_T_imu, est)
        self.assertAlmostEqual(rpe['rpe_percent'], 2.0, delta=0.05)
        self.assertLess(rpe['rpe_rot_deg_per_100m'], 1e-6)
        self.assertEqual(sorted(rpe['rpe_by_length'], key=int),
                         ['100', '200', '300', '400', '500', '600', '700', '800'])
        for by_length in rpe['rpe_by_length'].values():
            self.assertGreater(by_length['segments'], 0)
            self.assertAlmostEqual(by_length['trans_percent'], 2.0, delta=0.1)
        self.assertIsNone(rpe['rpe_note'])
        # The same through the whole evaluation (association, no influence of the alignment).
        result = metrics.evaluate_trajectory(t, est, t, gtworld_T_imu)
        self.assertAlmostEqual(result['rpe_percent'], rpe['rpe_percent'], delta=1e-12)

    def test_rpe_rotation_error_per_100m(self):
        # Straight 300 m path; the estimate turns 0.001 rad per metre about its vertical axis.
        _, gtworld_T_imu = straight_trajectory(301)
        est = np.empty_like(gtworld_T_imu)
        est[0] = np.eye(4)
        for k in range(1, len(est)):
            est[k] = est[k - 1] @ se3.se3_exp([1.0, 0, 0, 0, 0, 0.001])
        rpe = metrics.rpe_kitti(gtworld_T_imu, est, lengths=(100.0,))
        self.assertAlmostEqual(rpe['rpe_rot_deg_per_100m'], np.degrees(0.1), delta=1e-9)

    def test_rpe_segments_follow_the_kitti_rule(self):
        # 1 m per frame, 121 frames: 100 m segments start at frames 0, 10, 20 (ends 100, 110, 120).
        _, T = straight_trajectory(121)
        rpe = metrics.rpe_kitti(T, T, lengths=(100.0, 200.0))
        self.assertEqual(rpe['rpe_by_length']['100']['segments'], 3)
        self.assertEqual(rpe['rpe_by_length']['200']['segments'], 0)
        self.assertIsNone(rpe['rpe_by_length']['200']['trans_percent'])
        self.assertEqual(rpe['rpe_segments'], 3)

    def test_rpe_is_null_for_a_50_m_path(self):
        t, T = straight_trajectory(51)
        result = metrics.evaluate_trajectory(t, T, t, T)
        self.assertIsNone(result['rpe_percent'])
        self.assertIsNone(result['rpe_rot_deg_per_100m'])
        self.assertEqual(result['rpe_segments'], 0)
        self.assertIn('shorter', result['rpe_note'])
        self.assertLess(result['ate_rmse_m'], 1e-9)


class ConsistencyTest(unittest.TestCase):
    """NEES on known Gaussian samples: errors drawn from the claimed covariance give a mean near
    the dimension and 95 % inside the bound; errors twice as large give four times the mean."""

    @staticmethod
    def sample(n, scale, seed):
        rng = np.random.default_rng(seed)
        A = rng.normal(size=(n, 6, 6)) * 0.1
        P = np.einsum('nij,nkj->nik', A, A) + np.eye(6) * 1e-3
        L = np.linalg.cholesky(P)
        errors = scale * np.einsum('nij,nj->ni', L, rng.normal(size=(n, 6)))
        return errors, P

    def test_nees_of_matched_gaussian_errors(self):
        errors, P = self.sample(20000, 1.0, 1)
        pose = metrics.nees_stats(metrics.nees(errors, P), 6)
        position = metrics.nees_stats(metrics.nees(errors[:, :3], P[:, :3, :3]), 3)
        self.assertAlmostEqual(pose['mean'], 6.0, delta=0.15)
        self.assertAlmostEqual(position['mean'], 3.0, delta=0.08)
        self.assertAlmostEqual(pose['inside_95'], 0.95, delta=0.01)
        self.assertAlmostEqual(position['inside_95'], 0.95, delta=0.01)

    def test_error_over_sigma_per_axis(self):
        # Right about every axis but the fourth, whose variance is 4 times too large (its sigma 2x).
        errors, P = self.sample(20000, 1.0, 4)
        wide = P.copy()
        scale = np.ones(6)
        scale[3] = 2.0
        wide = wide * np.outer(scale, scale)[None]
        axes = metrics.normalized_error_rms(errors, wide)
        for i in (0, 1, 2, 4, 5):
            self.assertAlmostEqual(axes[i], 1.0, delta=0.03)
        self.assertAlmostEqual(axes[3], 0.5, delta=0.02)

    def test_nees_of_overconfident_covariance(self):
        errors, P = self.sample(20000, 2.0, 2)
        pose = metrics.nees_stats(metrics.nees(errors, P), 6)
        self.assertAlmostEqual(pose['mean'], 24.0, delta=0.8)
        self.assertLess(pose['inside_95'], 0.5)

    def test_pose_errors_follow_the_left_perturbation_in_the_estimator_gauge(self):
        rng = np.random.default_rng(3)
        n = 50
        truth = np.tile(np.eye(4), (n, 1, 1))
        for k in range(n):
            truth[k, :3, :3] = se3.so3_exp(rng.normal(size=3))
            truth[k, :3, 3] = rng.normal(size=3) * 10.0
        eps = rng.normal(size=(n, 6)) * 1e-4
        eps[0] = 0.0
        # The estimate: world_T_imu = exp(eps^) world_T_imu_true, in a world rotated and moved.
        world = np.eye(4)
        world[:3, :3] = se3.so3_exp(np.array([0.3, -0.2, 1.0]))
        world[:3, 3] = [5.0, -3.0, 2.0]
        est = np.empty_like(truth)
        for k in range(n):
            E = np.eye(4)
            E[:3, :3] = se3.so3_exp(eps[k, 3:])
            est[k] = world @ E @ truth[k]
            est[k, :3, 3] = (world @ truth[k])[:3, 3] + world[:3, :3] @ eps[k, :3]
        errors = metrics.pose_errors_in_estimator_gauge(est, truth)
        # Errors come out in the estimator's world axes.
        expected = np.hstack([eps[:, :3] @ world[:3, :3].T, eps[:, 3:] @ world[:3, :3].T])
        np.testing.assert_allclose(errors, expected, atol=1e-9)


class LandmarkTest(unittest.TestCase):
    def test_known_offsets_duplicates_and_unknown_ids(self):
        rng = np.random.default_rng(8)
        gt_ids = np.arange(10, 20)
        gtworld_xyz = rng.normal(0, 30, (10, 3))
        offsets = np.array([0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9])
        directions = rng.normal(size=(10, 3))
        directions /= np.linalg.norm(directions, axis=1, keepdims=True)
        est_gtworld = gtworld_xyz + offsets[:, None] * directions
        # Estimated rows: all ten, a second estimate of id 12 (3 m off) and an unknown id 99.
        est_ids = np.concatenate([gt_ids, [12, 99]])
        est_gtworld = np.vstack([est_gtworld, gtworld_xyz[2] + [3.0, 0, 0], [0, 0, 0]])
        estworld_T_gtworld = random_rigid(rng)
        estworld_xyz = est_gtworld @ estworld_T_gtworld[:3, :3].T + estworld_T_gtworld[:3, 3]
        result = metrics.landmark_errors(est_ids, estworld_xyz, gt_ids, gtworld_xyz,
                                         se3.inverse(estworld_T_gtworld))
        expected = np.concatenate([offsets, [3.0]])
        self.assertEqual(result['landmarks_matched'], 11)
        self.assertEqual(result['landmarks_estimated'], 12)
        np.testing.assert_allclose(result['errors'], expected, atol=1e-9)
        self.assertAlmostEqual(result['landmark_rmse_m'], np.sqrt(np.mean(expected ** 2)),
                               delta=1e-9)
        self.assertAlmostEqual(result['landmark_median_m'], 0.5, delta=1e-9)
        self.assertIsNone(result['landmark_within_3sigma'])

    def test_within_3sigma_uses_the_estimator_frame(self):
        # gtworld_T_estworld rotates by 90 deg about z: estimator x = ground-truth y.
        gtworld_T_estworld = se3.se3_exp([1.0, 2.0, 3.0, 0, 0, np.pi / 2])
        gtworld_xyz = np.zeros((4, 3))
        error_estworld = np.array([[2.0, 0, 0], [0, 2.0, 0], [0, 0, 0.2], [0, 0, 0.4]])
        sigma_estworld = np.array([[1.0, 0.1, 0.1], [1.0, 0.1, 0.1], [1.0, 0.1, 0.1],
                                   [1.0, 0.1, 0.1]])
        estworld_T_gtworld = se3.inverse(gtworld_T_estworld)
        estworld_xyz = (gtworld_xyz @ estworld_T_gtworld[:3, :3].T + estworld_T_gtworld[:3, 3]
                        + error_estworld)
        result = metrics.landmark_errors(np.arange(4), estworld_xyz, np.arange(4), gtworld_xyz,
                                         gtworld_T_estworld, sigma_estworld)
        np.testing.assert_allclose(result['errors'], [2.0, 2.0, 0.2, 0.4], atol=1e-9)
        # Mahalanobis^2: 4 (in), 400 (out), 4 (in), 16 (out, > 14.16).
        self.assertAlmostEqual(result['landmark_within_3sigma'], 0.5)
        self.assertEqual(result['landmarks_with_sigma'], 4)

    def test_read_landmarks_csv(self):
        tmp = tempfile.mkdtemp()
        self.addCleanup(shutil.rmtree, tmp)
        path = os.path.join(tmp, 'landmarks.csv')
        with open(path, 'w') as f:
            f.write('id,x,y,z,sigma_x,sigma_y,sigma_z,observations\n3,1,2,3,0.1,0.2,0.3,7\n')
        ids, xyz, sigma = metrics.read_landmarks_csv(path, require_sigma=True)
        np.testing.assert_array_equal(ids, [3])
        np.testing.assert_array_equal(xyz, [[1, 2, 3]])
        np.testing.assert_array_equal(sigma, [[0.1, 0.2, 0.3]])
        with open(path, 'w') as f:
            f.write('a,b,c\n1,2,3\n')
        with self.assertRaisesRegex(metrics.EvaluationError, 'landmarks.csv.*lacks'):
            metrics.read_landmarks_csv(path)


class CommandLineTest(unittest.TestCase):
    """scripts/evaluate.py end to end on generated files."""

    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.mkdtemp(prefix='test_evaluate_')
        rng = np.random.default_rng(9)
        t, gtworld_T_imu = curvy_trajectory(400)
        cls.gt_path = os.path.join(cls.tmp, 'gt.tum')
        trajectory.write_tum(cls.gt_path, t, gtworld_T_imu)
        estworld_T_gtworld = random_rigid(rng)
        cls.estimates = []
        for name, noise in (('slam', 0.2), ('deadreckoning', 2.0)):
            noisy = gtworld_T_imu.copy()
            noisy[:, :3, 3] += rng.normal(0, noise, (len(t), 3))
            keep = rng.random(len(t)) > 0.1  # some poses missing
            os.makedirs(os.path.join(cls.tmp, name))
            path = os.path.join(cls.tmp, name, 'trajectory.tum')
            trajectory.write_tum(path, t[keep] + 0.004, transform_poses(estworld_T_gtworld,
                                                                        noisy[keep]))
            cls.estimates.append(path)
        n = 2000
        lm_gtworld = gtworld_T_imu[rng.integers(0, len(t), n), :3, 3] + rng.normal(0, 10, (n, 3))
        sigma = rng.uniform(0.1, 1.0, (n, 3))
        lm_estworld = (lm_gtworld @ estworld_T_gtworld[:3, :3].T + estworld_T_gtworld[:3, 3]
                       + rng.normal(size=(n, 3)) * sigma)
        cls.landmarks = os.path.join(cls.tmp, 'slam', 'landmarks.csv')
        with open(cls.landmarks, 'w') as f:
            f.write('id,x,y,z,sigma_x,sigma_y,sigma_z,observations\n')
            for i in range(n):
                f.write('%d,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,4\n' % ((i,) + tuple(lm_estworld[i])
                                                                + tuple(sigma[i])))
        cls.landmarks_gt = os.path.join(cls.tmp, 'true_landmarks.csv')
        with open(cls.landmarks_gt, 'w') as f:
            f.write('id,x,y,z\n')
            for i in range(n):
                f.write('%d,%.6f,%.6f,%.6f\n' % ((i,) + tuple(lm_gtworld[i])))

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.tmp)

    def run_evaluate(self, *args):
        env = dict(os.environ)
        env['PYTHONPATH'] = SRC + os.pathsep + env.get('PYTHONPATH', '')
        return subprocess.run(['/usr/bin/python3', EVALUATE] + list(args), env=env,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              universal_newlines=True, timeout=60)

    def assert_one_line_error(self, proc, *fragments):
        self.assertEqual(proc.returncode, 2, proc.stderr)
        self.assertNotIn('Traceback', proc.stderr)
        lines = proc.stderr.strip().splitlines()
        self.assertEqual(len(lines), 1, proc.stderr)
        for fragment in fragments:
            self.assertIn(fragment, lines[0])

    def test_comparison_with_landmarks(self):
        out = os.path.join(self.tmp, 'out_comparison')
        proc = self.run_evaluate('--groundtruth', self.gt_path,
                                 '--estimate', self.estimates[0], '--label', 'ekf slam',
                                 '--estimate', self.estimates[1],
                                 '--landmarks', self.landmarks, '--landmarks-gt', self.landmarks_gt,
                                 '--out', out)
        self.assertEqual(proc.returncode, 0, proc.stderr)
        with open(os.path.join(out, 'metrics.json')) as f:
            report = json.load(f)
        self.assertEqual(report['groundtruth'], self.gt_path)
        self.assertEqual(list(report['estimates']), ['ekf slam', 'deadreckoning'])
        for label, noise in (('ekf slam', 0.2), ('deadreckoning', 2.0)):
            r = report['estimates'][label]
            for key in ('ate_rmse_m', 'ate_mean_m', 'ate_median_m', 'ate_max_m',
                        'rotation_rmse_deg', 'rpe_percent', 'rpe_rot_deg_per_100m',
                        'rpe_by_length', 'final_position_error_m', 'path_length_m',
                        'matched_poses'):
                self.assertIn(key, r)
            expected_ate = noise * np.sqrt(3)
            self.assertAlmostEqual(r['ate_rmse_m'], expected_ate, delta=0.15 * expected_ate)
            self.assertGreater(r['matched_poses'], 300)
            self.assertLess(r['matched_poses'], 400)
            self.assertLess(r['rotation_rmse_deg'], 0.5)  # only the alignment's rotation error
            self.assertAlmostEqual(r['path_length_m'], 399.0, delta=1.0)
        primary = report['estimates']['ekf slam']
        self.assertEqual(primary['landmarks_matched'], 2000)
        self.assertLess(primary['landmark_rmse_m'], 1.5)
        self.assertGreater(primary['landmark_within_3sigma'], 0.95)
        self.assertNotIn('landmarks_matched', report['estimates']['deadreckoning'])
        for png in ('trajectory_topdown.png', 'error_along_path.png', 'comparison.png'):
            self.assertGreater(os.path.getsize(os.path.join(out, png)), 1000, png)
        self.assertIn('ekf slam', proc.stdout)
        self.assertIn('deadreckoning', proc.stdout)

    def test_per_pose_consistency_shows_where_the_covariance_is_too_narrow(self):
        # Pose errors drawn from a claimed covariance (the estimator's left perturbation, world
        # axes), three times larger over the second half: its NEES nine times the first half's.
        rng = np.random.default_rng(12)
        t, truth = curvy_trajectory(300, seed=4)
        sigmas = np.array([0.3, 0.2, 0.1, 0.004, 0.003, 0.005])
        scale = np.where(np.arange(len(t)) < 150, 1.0, 3.0)
        eps = rng.normal(size=(len(t), 6)) * sigmas * scale[:, None]
        eps[0] = 0.0
        est = truth.copy()
        for k in range(len(t)):
            est[k, :3, :3] = se3.so3_exp(eps[k, 3:]) @ truth[k, :3, :3]
            est[k, :3, 3] = truth[k, :3, 3] + eps[k, :3]
        folder = os.path.join(self.tmp, 'ekf run')
        os.makedirs(folder)
        trajectory.write_tum(os.path.join(folder, 'trajectory.tum'), t, est)
        P = np.tile(np.diag(sigmas ** 2), (len(t), 1, 1))
        np.savetxt(os.path.join(folder, 'trajectory_covariance.txt'),
                   np.column_stack([t, P.reshape(len(t), 36)]), fmt='%.12g')
        out = os.path.join(self.tmp, 'out_consistency')
        proc = self.run_evaluate('--groundtruth', self.gt_path_for(t, truth), '--estimate',
                                 os.path.join(folder, 'trajectory.tum'), '--label', 'ekf slam',
                                 '--out', out)
        self.assertEqual(proc.returncode, 0, proc.stderr)
        with open(os.path.join(out, 'metrics.json')) as f:
            summary = json.load(f)['estimates']['ekf slam']
        rows = np.genfromtxt(os.path.join(out, 'consistency_ekf_slam.csv'), delimiter=',',
                             names=True)
        self.assertEqual(len(rows), len(t) - 1)  # the first pose defines the gauge
        np.testing.assert_allclose(rows['t'], t[1:], atol=1e-6)
        self.assertAlmostEqual(float(np.mean(rows['position_nees'])),
                               summary['nees_position']['mean'], places=6)
        self.assertAlmostEqual(float(np.mean(rows['pose_nees'])),
                               summary['nees_pose']['mean'], places=6)
        for i, axis in enumerate(metrics.POSE_AXES):
            np.testing.assert_allclose(rows['sigma_' + axis], sigmas[i], rtol=1e-6)
            np.testing.assert_allclose(rows['error_' + axis], eps[1:, i], atol=1e-6)
        first, second = rows['pose_nees'][:149], rows['pose_nees'][149:]
        self.assertAlmostEqual(float(np.mean(first)), 6.0, delta=1.2)
        self.assertAlmostEqual(float(np.mean(second)), 54.0, delta=11.0)
        self.assertGreater(os.path.getsize(os.path.join(out, 'consistency_ekf_slam.png')), 1000)

    def test_consistency_files_of_labels_alike_do_not_overwrite_each_other(self):
        spec = importlib.util.spec_from_file_location('evaluate_script', EVALUATE)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        self.assertEqual(module.consistency_file_stems(['ekf slam', 'ekf_slam', 'ekf/slam', 'dr']),
                         {'ekf slam': 'consistency_ekf_slam', 'ekf_slam': 'consistency_ekf_slam-2',
                          'ekf/slam': 'consistency_ekf_slam-3', 'dr': 'consistency_dr'})

    def gt_path_for(self, t, truth):
        path = os.path.join(self.tmp, 'gt_consistency.tum')
        trajectory.write_tum(path, t, truth)
        return path

    def test_single_estimate_writes_no_comparison(self):
        out = os.path.join(self.tmp, 'out_single')
        proc = self.run_evaluate('--groundtruth', self.gt_path, '--estimate', self.estimates[0],
                                 '--out', out)
        self.assertEqual(proc.returncode, 0, proc.stderr)
        with open(os.path.join(out, 'metrics.json')) as f:
            report = json.load(f)
        self.assertEqual(list(report['estimates']), ['slam'])  # label from the folder name
        self.assertTrue(os.path.getsize(os.path.join(out, 'trajectory_topdown.png')) > 0)
        self.assertTrue(os.path.getsize(os.path.join(out, 'error_along_path.png')) > 0)
        self.assertFalse(os.path.exists(os.path.join(out, 'comparison.png')))
        self.assertFalse(os.path.exists(os.path.join(out, 'consistency_slam.csv')))  # no covariance

    def test_kitti_poses_with_the_dataset_they_came_from(self):
        """A KITTI poses file (world_T_cam0) read through a 2019-layout dataset: its frame times,
        and its cam_T_imu with the translation corrected as dataset_to_bag.py does."""
        t, gtworld_T_imu = trajectory.read_tum(self.gt_path)
        cam_T_imu = se3.se3_exp([0.3, -0.7, 1.1, 1.2, -1.2, 1.2])
        world_T_cam0 = np.einsum('nij,jk->nik', gtworld_T_imu, se3.inverse(cam_T_imu))
        poses = os.path.join(self.tmp, 'poses.txt')
        np.savetxt(poses, world_T_cam0[:, :3, :].reshape(len(t), 12))
        stored = cam_T_imu.copy()  # the 2019 files hold imu_T_cam's translation
        stored[:3, 3] = se3.inverse(cam_T_imu)[:3, 3]
        n = len(t)
        npz = os.path.join(self.tmp, 'course_2019.npz')
        np.savez(npz, time_stamps=t[None, :], features=-np.ones((4, 1, n)),
                 linear_velocity=np.zeros((3, n)), rotational_velocity=np.zeros((3, n)),
                 K=np.array([[700.0, 0, 600], [0, 700.0, 180], [0, 0, 1]]), b=0.54,
                 cam_T_imu=stored)
        out = os.path.join(self.tmp, 'out_kitti')
        proc = self.run_evaluate('--groundtruth', poses, '--dataset', npz,
                                 '--estimate', self.gt_path, '--label', 'gt', '--out', out)
        self.assertEqual(proc.returncode, 0, proc.stderr)
        with open(os.path.join(out, 'metrics.json')) as f:
            report = json.load(f)['estimates']['gt']
        self.assertEqual(report['matched_poses'], n)
        self.assertLess(report['ate_rmse_m'], 1e-4)
        # The stored translation taken as it is puts the IMU 2.6 m away: the error shows.
        text = os.path.join(self.tmp, 'stored_cam_T_imu.txt')
        np.savetxt(text, stored)
        proc = self.run_evaluate('--groundtruth', poses, '--frame-times', npz, '--cam-T-imu', text,
                                 '--estimate', self.gt_path, '--label', 'gt',
                                 '--out', out + '_stored')
        self.assertEqual(proc.returncode, 0, proc.stderr)
        with open(os.path.join(out + '_stored', 'metrics.json')) as f:
            self.assertGreater(json.load(f)['estimates']['gt']['ate_rmse_m'], 0.05)
        proc = self.run_evaluate('--groundtruth', poses, '--estimate', self.gt_path,
                                 '--out', out + '_without')
        self.assert_one_line_error(proc, poses, 'frame times and cam_T_imu')
        proc = self.run_evaluate('--groundtruth', poses, '--dataset', poses,
                                 '--estimate', self.gt_path, '--out', out + '_bad')
        self.assert_one_line_error(proc, poses)

    def test_missing_file(self):
        missing = os.path.join(self.tmp, 'no_such_dir', 'trajectory.tum')
        proc = self.run_evaluate('--groundtruth', self.gt_path, '--estimate', missing,
                                 '--out', os.path.join(self.tmp, 'out_missing'))
        self.assert_one_line_error(proc, missing)
        proc = self.run_evaluate('--groundtruth', missing, '--estimate', self.estimates[0],
                                 '--out', os.path.join(self.tmp, 'out_missing'))
        self.assert_one_line_error(proc, missing)

    def test_malformed_tum(self):
        bad = os.path.join(self.tmp, 'bad.tum')
        with open(bad, 'w') as f:
            f.write('1.0 2.0 3.0 4.0 0 0 0 1\n1.1 2.0 oops\n')
        proc = self.run_evaluate('--groundtruth', self.gt_path, '--estimate', bad,
                                 '--out', os.path.join(self.tmp, 'out_bad'))
        self.assert_one_line_error(proc, bad)

    def test_too_few_matches(self):
        shifted = os.path.join(self.tmp, 'shifted.tum')
        t, T = trajectory.read_tum(self.gt_path)
        trajectory.write_tum(shifted, t + 1000.0, T)
        proc = self.run_evaluate('--groundtruth', self.gt_path, '--estimate', shifted,
                                 '--out', os.path.join(self.tmp, 'out_shifted'))
        self.assert_one_line_error(proc, shifted, 'only 0 of 400')


if __name__ == '__main__':
    unittest.main()
