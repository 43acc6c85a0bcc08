"""End-to-end regression: dataset -> bag -> vislam_offline -> accuracy against ground truth.

Synthetic drives always (the project's simulator, default settings); the KITTI sequences 0027 and
0034 when ../shared/data (or EKF_VISLAM_DATA) is there. The bounds guard the figures measured with
the shipped config/default.yaml (README "Results"), with margin; the README states where they
fall short of the targets.
"""
import json
import os
import shutil
import subprocess
import unittest

import numpy as np

import ekf_test_paths as paths
from ekf_vislam_tools import metrics, trajectory

SCRIPTS = os.path.join(paths.REPO_ROOT, 'scripts')
PY = '/usr/bin/python3'


def check(proc):
    """A finished subprocess that must have succeeded: its command and output if it did not."""
    if proc.returncode != 0:
        raise AssertionError('%s failed (%d):\n%s%s' % (' '.join(map(str, proc.args)),
                                                        proc.returncode, proc.stdout, proc.stderr))
    return proc


def run(cmd):
    return check(subprocess.run(cmd, capture_output=True, text=True))


def offline(bag, mode, out_dir, *extra):
    check(paths.run_vislam_offline(bag, out_dir, '--mode', mode, *extra))
    with open(os.path.join(out_dir, 'stats.json')) as f:
        stats = json.load(f)
    return trajectory.read_tum(os.path.join(out_dir, 'trajectory.tum')), stats


def accuracy(estimate, groundtruth_path):
    t, T = estimate
    tg, Tg = trajectory.read_tum(groundtruth_path)
    return metrics.evaluate_trajectory(t, T, tg, Tg)


def consistency(run_dir, groundtruth_path):
    """Position and pose NEES of a vislam_offline run (trajectory_covariance.txt) against ground
    truth, in the estimator's gauge."""
    t, T = trajectory.read_tum(os.path.join(run_dir, 'trajectory.tum'))
    t_cov, covariances = metrics.read_trajectory_covariance(
        os.path.join(run_dir, 'trajectory_covariance.txt'))
    tg, Tg = trajectory.read_tum(groundtruth_path)
    return metrics.consistency(t, T, t_cov, covariances, tg, Tg)


def map_consistency(run_dir, groundtruth_path, reference_csv):
    """The map's NEES (diagonal sigmas, 3 is consistent) and its landmark count against reference
    landmarks, in the estimator's gauge, as evaluate.py reads it."""
    t, T = trajectory.read_tum(os.path.join(run_dir, 'trajectory.tum'))
    tg, Tg = trajectory.read_tum(groundtruth_path)
    matched = metrics.match_and_align(t, T, tg, Tg)
    ids, xyz, sigma = metrics.read_landmarks_csv(os.path.join(run_dir, 'landmarks.csv'))
    ref_ids, ref_xyz, _ = metrics.read_landmarks_csv(reference_csv)
    result = metrics.landmark_errors(ids, xyz, ref_ids, ref_xyz, matched.gtworld_T_estworld,
                                     sigma, metrics.estimator_gauge(matched))
    return result['landmark_nees'], result['landmarks_matched']


class SyntheticDriveTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = paths.make_temp_dir()
        cls.addClassCleanup(shutil.rmtree, cls.tmp, True)
        cls.results = {}
        exact_config = cls.exact_config()
        for seed in (11, 12):
            prefix = os.path.join(cls.tmp, 'sim%d' % seed)
            run([PY, os.path.join(SCRIPTS, 'simulate_dataset.py'), '--seed', str(seed), '--out', prefix])
            run([PY, os.path.join(SCRIPTS, 'dataset_to_bag.py'), prefix + '.npz', prefix + '.bag'])
            for mode in ('slam', 'mapping', 'deadreckoning'):
                out = os.path.join(cls.tmp, 'sim%d_%s' % (seed, mode))
                estimate, stats = offline(prefix + '.bag', mode, out)
                cls.results[(seed, mode)] = (estimate, stats, accuracy(estimate, prefix + '_groundtruth.tum'))
            # The simulator's disparities are exact: SLAM again without the counted disparity
            # offset (intrinsic/disparity_offset_counted_sigma), as a filter matched to it.
            out = os.path.join(cls.tmp, 'sim%d_slam_exact' % seed)
            estimate, stats = offline(prefix + '.bag', 'slam', out, '--config', exact_config)
            cls.results[(seed, 'slam_exact')] = (estimate, stats, None)

    @classmethod
    def exact_config(cls):
        path = os.path.join(cls.tmp, 'exact_disparities.yaml')
        with open(path, 'w') as f:
            f.write('intrinsic:\n  disparity_offset_counted_sigma: 0.0\n')
        return path

    def test_slam_accuracy_on_synthetic_drives(self):
        for seed in (11, 12):
            ate = self.results[(seed, 'slam')][2]['ate_rmse_m']
            dead = self.results[(seed, 'deadreckoning')][2]['ate_rmse_m']
            print('seed %d: SLAM ATE %.3f m, dead reckoning %.3f m' % (seed, ate, dead))
            self.assertLess(ate, 1.0)
            self.assertLess(ate, 0.2 * dead)

    def test_white_tracks_are_not_inflated(self):
        # The simulator's tracks have white errors: the estimated track correlation stays small
        # and the reported covariance stays consistent (position NEES in 1-12) with the disparity
        # offset counted as the simulation has it (none). With the shipped 0.1 px counted it is
        # wider, as on every drive with exact disparities (measured 1.92 -> 1.67 and 1.02 -> 0.48
        # for seeds 11 and 12, doc/experiments.md), but not without bound.
        for seed in (11, 12):
            stats = self.results[(seed, 'slam_exact')][1]
            groundtruth = os.path.join(self.tmp, 'sim%d_groundtruth.tum' % seed)
            nees = consistency(os.path.join(self.tmp, 'sim%d_slam_exact' % seed), groundtruth)
            nees = nees['nees_position']['mean']
            shipped = consistency(os.path.join(self.tmp, 'sim%d_slam' % seed), groundtruth)
            shipped = shipped['nees_position']['mean']
            print('seed %d: track correlation %.3f, position NEES %.2f (shipped options %.2f)' % (
                seed, stats['track_correlation'], nees, shipped))
            self.assertLess(stats['track_correlation'], 0.2)
            self.assertGreater(nees, 1.0)
            self.assertLess(nees, 12.0)
            self.assertGreater(shipped, 0.2)
            self.assertLess(shipped, nees)

    def test_mapping_keeps_the_dead_reckoned_pose_and_builds_a_map(self):
        for seed in (11, 12):
            (t_map, T_map), stats_map, _ = self.results[(seed, 'mapping')]
            (t_dr, T_dr), stats_dr, _ = self.results[(seed, 'deadreckoning')]
            np.testing.assert_allclose(T_map[:, :3, 3], T_dr[:, :3, 3], atol=1e-6)
            self.assertGreater(stats_map['landmarks'], 1000)
            self.assertEqual(stats_dr['landmarks'], 0)

    def test_statistics_are_complete(self):
        _, stats, _ = self.results[(11, 'slam')]
        self.assertEqual(stats['frames'], stats['twists'])
        self.assertGreater(stats['counters']['observation_update'], 10 * stats['frames'])
        self.assertGreater(stats['counters']['observation_gated'], 0)  # the simulator's outliers
        self.assertLessEqual(stats['peak_active_landmarks'], 300)  # bounded state

    def test_an_invalid_calibration_override_stops_every_mode(self):
        # A cam_T_imu whose rotation is not a rotation: refused even where no calibration is
        # needed (dead reckoning), instead of being ignored.
        config = os.path.join(self.tmp, 'bad_calibration.yaml')
        with open(config, 'w') as f:
            f.write('ros:\n  calibration:\n    cam_T_imu: "2 0 0 0  0 2 0 0  0 0 2 0  0 0 0 1"\n')
        for mode in ('slam', 'deadreckoning'):
            proc = paths.run_vislam_offline(
                os.path.join(self.tmp, 'sim11.bag'), os.path.join(self.tmp, 'bad_' + mode),
                '--mode', mode, '--config', config)
            self.assertNotEqual(proc.returncode, 0, mode)
            self.assertIn('invalid calibration', proc.stderr, mode)
            self.assertIn('not a rotation', proc.stderr, mode)


class StopTest(unittest.TestCase):
    # A simulated drive with a 30-s stop (traffic lights), its wheel odometry reading exactly 0 at
    # rest. Before the twist-noise estimate left held values out, the stop set the estimated
    # linear noise to zero and after it the filter took the twist for exact: SLAM ATE 1.216 m,
    # position / pose NEES 8.02 / 128.31 on this seed; then 0.214 m, 1.05 / 1.62 (the drive without
    # the stop: 0.434 m, 1.53 / 2.09). Since the simulated tracks keep their error at rest (the same
    # view gives the same track), the stop driven through (standstill/enabled: false) gives 0.247 m,
    # 0.37 / 1.75, and held at rest (the default) 0.141 m, 0.20 / 1.01.

    def test_a_stop_keeps_the_covariance_honest(self):
        tmp = paths.make_temp_dir(self)
        prefix = os.path.join(tmp, 'stop')
        run([PY, os.path.join(SCRIPTS, 'simulate_dataset.py'), '--seed', '2', '--frames', '1000',
             '--stop', '30', '30', '--out', prefix])
        run([PY, os.path.join(SCRIPTS, 'dataset_to_bag.py'), prefix + '.npz', prefix + '.bag'])
        slam_dir = os.path.join(tmp, 'slam')
        ate = accuracy(offline(prefix + '.bag', 'slam', slam_dir)[0],
                       prefix + '_groundtruth.tum')['ate_rmse_m']
        nees = consistency(slam_dir, prefix + '_groundtruth.tum')
        position, pose = nees['nees_position']['mean'], nees['nees_pose']['mean']
        print('30-s stop: SLAM ATE %.3f m, position / pose NEES %.2f / %.2f' % (ate, position, pose))
        self.assertLess(ate, 0.2)
        self.assertLess(position, 6.0)
        self.assertLess(pose, 8.0)


@unittest.skipUnless(paths.data_dir(), 'course datasets not found (../shared/data or EKF_VISLAM_DATA)')
class KittiRegressionTest(unittest.TestCase):
    # Measured with config/default.yaml (scripts/benchmark.sh): 0027 2.006 m / 1.23 %, mean
    # position NEES 1.77; 0034 5.546 m / 2.35 %, NEES 1.53 (README; 3.52 before its road tilt's
    # excess was counted as tilt error, 1.82 before a disparity offset of 0.1 px was counted, 1.64
    # before that offset grew to what the observations read, 1.56 before the frames before the
    # track correlation's first estimate were recounted at it, doc/estimator.md). The run is
    # deterministic; the
    # bounds are the consistency targets (ATE 2.5 and 6.0 m, RPE 2 and 3 %). The NEES must lie in
    # the consistency band 1.5-6 (3 is exact). Dead reckoning's heading is known to tens of degrees
    # by the end (its gyro bias is not observed): its reported pose covariance must not be
    # overconfident either (pose NEES 0.66 / 1.98; 4.39 / 72.45 with the linear covariance).
    BOUNDS = {'0027': (2.5, 2.0), '0034': (6.0, 3.0)}  # (ATE m, RPE %)
    NEES_BAND = (1.5, 6.0)
    # The map against the reference landmarks (landmark_reference.py), diagonal NEES: measured
    # 2.01 (0027) and 2.25 (0034), in mapping mode 0.73 and 0.88 (212706.86 and 3546584.66 before
    # its covariance carried the dead-reckoned pose's error); a lower bound (doc/estimator.md, The
    # map).
    MAP_NEES_MAX = 4.0
    DEAD_RECKONING_POSE_NEES_MAX = 6.0

    def check(self, name):
        data = paths.data_dir()
        tmp = paths.make_temp_dir(self)
        bag = os.path.join(tmp, name + '.bag')
        run([PY, os.path.join(SCRIPTS, 'dataset_to_bag.py'), os.path.join(data, name + '.npz'), bag])
        gt = os.path.join(data, 'groundtruth', name + '_imu_gt.tum')
        slam_dir = os.path.join(tmp, 'slam')
        slam = accuracy(offline(bag, 'slam', slam_dir)[0], gt)
        nees = consistency(slam_dir, gt)['nees_position']['mean']
        dead_dir = os.path.join(tmp, 'dr')
        dead = accuracy(offline(bag, 'deadreckoning', dead_dir)[0], gt)
        dead_nees = consistency(dead_dir, gt)['nees_pose']['mean']
        # The map against each track triangulated from the ground-truth poses (a lower bound of
        # its NEES: the reference shares the tracks' own errors).
        reference = os.path.join(tmp, 'reference.csv')
        run([PY, os.path.join(SCRIPTS, 'landmark_reference.py'), os.path.join(data, name + '.npz'),
             '--groundtruth', gt, '--out', reference])
        map_nees, map_matched = map_consistency(slam_dir, gt, reference)
        # Mapping places the landmarks from the dead-reckoned poses: the map carries their error.
        mapping_dir = os.path.join(tmp, 'mapping')
        offline(bag, 'mapping', mapping_dir)
        mapping_nees, mapping_matched = map_consistency(mapping_dir, gt, reference)
        print('%s: SLAM ATE %.3f m RPE %.2f %% position NEES %.2f, map NEES %.2f (%d landmarks), '
              'mapping map NEES %.2f (%d), dead reckoning ATE %.3f m, pose NEES %.2f' % (
                  name, slam['ate_rmse_m'], slam['rpe_percent'], nees, map_nees, map_matched,
                  mapping_nees, mapping_matched, dead['ate_rmse_m'], dead_nees))
        self.assertLess(dead_nees, self.DEAD_RECKONING_POSE_NEES_MAX)
        self.assertGreater(map_matched, 3000)
        self.assertLess(map_nees, self.MAP_NEES_MAX)
        self.assertGreater(mapping_matched, 2000)
        self.assertLess(mapping_nees, self.MAP_NEES_MAX)
        ate_bound, rpe_bound = self.BOUNDS[name]
        self.assertGreater(nees, self.NEES_BAND[0])
        self.assertLess(nees, self.NEES_BAND[1])
        self.assertLess(slam['ate_rmse_m'], ate_bound)
        self.assertLess(slam['rpe_percent'], rpe_bound)
        self.assertLess(slam['ate_rmse_m'], 0.35 * dead['ate_rmse_m'])

    def test_0027(self):
        self.check('0027')

    def test_0034(self):
        self.check('0034')

    def check_accurate_twist_does_no_harm(self, name):
        # A twist as good as a decent wheel odometry (make_variant.py --twist accurate, seed 1),
        # every id: SLAM must stay below 0.9x dead reckoning (the bound).
        data = paths.data_dir()
        tmp = paths.make_temp_dir(self)
        gt = os.path.join(data, 'groundtruth', name + '_imu_gt.tum')
        variant = os.path.join(tmp, 'accurate.npz')
        run([PY, os.path.join(SCRIPTS, 'make_variant.py'), os.path.join(data, name + '.npz'),
             '--groundtruth', gt, '--twist', 'accurate', '--seed', '1', '--out', variant])
        bag = os.path.join(tmp, 'accurate.bag')
        run([PY, os.path.join(SCRIPTS, 'dataset_to_bag.py'), variant, bag])
        slam_dir = os.path.join(tmp, 'slam')
        slam = accuracy(offline(bag, 'slam', slam_dir)[0], gt)
        nees = consistency(slam_dir, gt)['nees_position']['mean']
        dead = accuracy(offline(bag, 'deadreckoning', os.path.join(tmp, 'dr'))[0], gt)
        print('%s accurate twist: SLAM ATE %.3f m, position NEES %.2f, dead reckoning %.3f m' % (
            name, slam['ate_rmse_m'], nees, dead['ate_rmse_m']))
        self.assertLess(slam['ate_rmse_m'], 0.9 * dead['ate_rmse_m'])
        # The tracks' correlation is estimated from the data, not told per regime: the same band.
        self.assertGreater(nees, KittiRegressionTest.NEES_BAND[0])
        self.assertLess(nees, KittiRegressionTest.NEES_BAND[1])

    def test_accurate_twist_0027_does_no_harm(self):
        # Measured: SLAM 1.220 m against dead reckoning 3.965 m (0.31x), position NEES 2.05.
        self.check_accurate_twist_does_no_harm('0027')

    def test_accurate_twist_0034_does_no_harm(self):
        # Measured: SLAM 3.961 m against dead reckoning 4.661 m (0.85x), position NEES 1.61 (2.83
        # before the road tilt's excess was counted).
        self.check_accurate_twist_does_no_harm('0034')

    def check_noisy_twist_is_reported_honestly(self, name, noise, gyro_offset, seed=1):
        # A twist noisier than the course files' (make_variant.py --twist accurate --twist-noise V
        # W --gyro-offset B --seed N): a sample far off in a frame where most landmarks then fail
        # their gates (often the first frames, before the twist's noise is estimated, or the frame
        # after a repeated one) must not keep its error with a good prediction's covariance (the
        # prediction check, doc/estimator.md, Update).
        data = paths.data_dir()
        tmp = paths.make_temp_dir(self)
        gt = os.path.join(data, 'groundtruth', name + '_imu_gt.tum')
        variant = os.path.join(tmp, 'noisy.npz')
        run([PY, os.path.join(SCRIPTS, 'make_variant.py'), os.path.join(data, name + '.npz'),
             '--groundtruth', gt, '--twist', 'accurate', '--twist-noise', str(noise[0]),
             str(noise[1]), '--gyro-offset', str(gyro_offset), '--seed', str(seed), '--out', variant])
        bag = os.path.join(tmp, 'noisy.bag')
        run([PY, os.path.join(SCRIPTS, 'dataset_to_bag.py'), variant, bag])
        slam_dir = os.path.join(tmp, 'slam')
        estimate, stats = offline(bag, 'slam', slam_dir)
        slam = accuracy(estimate, gt)
        nees = consistency(slam_dir, gt)['nees_position']['mean']
        widened = stats['counters']['frame_prediction_widened']
        print('%s twist %s rad/s, seed %d: SLAM ATE %.3f m, position NEES %.2f, %d frames widened'
              % (name, noise[1], seed, slam['ate_rmse_m'], nees, widened))
        self.assertGreater(widened, 0)
        self.assertLess(nees, 4.0)
        self.assertLess(slam['ate_rmse_m'], self.BOUNDS[name][0])

    def test_a_twist_four_times_as_noisy_in_angle_0027(self):
        # Measured: 0.2 rad/s per sample, SLAM ATE 1.493 m, position NEES 1.45 (9.306 m, 13.07
        # without the check; 9.883 m, 7.75 with it but counting the tracks seen from a repeated
        # frame, which the twist's error there does not reach).
        self.check_noisy_twist_is_reported_honestly('0027', (0.5, 0.2), 0.009)

    def test_a_twist_four_times_as_noisy_in_angle_from_its_first_samples_0034(self):
        # Seed 2: a yaw-rate sample 0.45 rad/s off at the repeated frame 5, before 5 second
        # differences have come, counted at the configured guess it turned the yaw 2.6 degrees
        # against a sigma of 0.3 (the tracks through the repeated frame do not see it): position
        # NEES 27.12. The first samples reject the guess (Propagator::kEarlyNoiseTestProbability):
        # measured SLAM ATE 5.070 m, position NEES 3.28, 34 frames widened.
        self.check_noisy_twist_is_reported_honestly('0034', (0.5, 0.2), 0.009, seed=2)

    def test_a_twist_twice_as_noisy_0034(self):
        # Measured: 1.0 m/s and 0.1 rad/s per sample, SLAM ATE 5.528 m, position NEES 1.22 (6.104
        # m, 13.30 without the check).
        self.check_noisy_twist_is_reported_honestly('0034', (1.0, 0.1), 0.009)

    def test_faults_and_outliers_cost_at_most_15_percent(self):
        # 0027 with every fault class, 5 % of the observations moved to random image positions and
        # an empty message every 113th frame (seed 1): 1.352 m against 2.014 m clean (0.67x;
        # seeds 2-4: 0.8957x-1.0040x, README). The bound is 1.15x.
        data = paths.data_dir()
        tmp = paths.make_temp_dir(self)
        gt = os.path.join(data, 'groundtruth', '0027_imu_gt.tum')
        clean = os.path.join(tmp, 'clean.bag')
        faulty = os.path.join(tmp, 'faulty.bag')
        run([PY, os.path.join(SCRIPTS, 'dataset_to_bag.py'), os.path.join(data, '0027.npz'), clean])
        run([PY, os.path.join(SCRIPTS, 'inject_faults.py'), clean, faulty, '--outlier-fraction',
             '0.05', '--empty-every', '113', '--seed', '1'])
        ate_clean = accuracy(offline(clean, 'slam', os.path.join(tmp, 'clean'))[0], gt)['ate_rmse_m']
        estimate, stats = offline(faulty, 'slam', os.path.join(tmp, 'faulty'))
        ate_faulty = accuracy(estimate, gt)['ate_rmse_m']
        print('0027 with faults and 5 %% outliers: SLAM ATE %.3f m, clean %.3f m' % (
            ate_faulty, ate_clean))
        self.assertLess(ate_faulty, 1.15 * ate_clean)
        # The re-sent frames are still recognized among the outliers.
        self.assertGreater(stats['counters']['frame_repeated'], 80)


if __name__ == '__main__':
    unittest.main()
