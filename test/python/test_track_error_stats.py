"""scripts/track_error_stats.py: on simulated drives with known pixel errors it recovers their std,
their frame-to-frame correlation and their random-walk rate (white and drifting tracks)."""
import json
import os
import sys
import unittest

import numpy as np

import ekf_test_paths

sys.path.insert(0, ekf_test_paths.SOURCE_DIR)
from ekf_vislam_tools import se3, trajectory  # noqa: E402


class TrackErrorStatsTest(unittest.TestCase):

    @classmethod
    def setUpClass(cls):
        cls.tmp = ekf_test_paths.make_temp_dir()
        cls.addClassCleanup(ekf_test_paths.remove_dir, cls.tmp)

    def stats(self, name, *simulator_args, estimated_poses=False):
        """The statistics of a simulated drive's tracks, against its ground truth or, with
        estimated_poses, against the trajectory vislam_offline estimates from it."""
        prefix = os.path.join(self.tmp, name)
        proc = ekf_test_paths.run_script('simulate_dataset.py', '--seed', 5, '--frames', 300,
                                         '--outlier-rate', 0, '--out', prefix, *simulator_args)
        self.assertEqual(proc.returncode, 0, proc.stderr)
        poses = prefix + '_groundtruth.tum'
        if estimated_poses:
            proc = ekf_test_paths.run_script('dataset_to_bag.py', prefix + '.npz',
                                             prefix + '.bag')
            self.assertEqual(proc.returncode, 0, proc.stderr)
            run = ekf_test_paths.run_vislam_offline(prefix + '.bag', prefix + '_run')
            self.assertEqual(run.returncode, 0, run.stderr)
            poses = os.path.join(prefix + '_run', 'trajectory.tum')
        out = prefix + '_stats.json'
        proc = ekf_test_paths.run_script('track_error_stats.py', prefix + '.npz', '--poses',
                                         poses, '--json', out)
        self.assertEqual(proc.returncode, 0, proc.stderr)
        self.assertIn('frame-to-frame correlation rho', proc.stdout)
        with open(out) as f:
            return json.load(f)

    def test_white_errors(self):
        s = self.stats('white')
        for std in s['std']:
            self.assertAlmostEqual(std, 1.0, delta=0.12)
        # The fitted landmark takes a little of each track's error: slightly negative.
        self.assertGreater(s['rho'], -0.15)
        self.assertLess(s['rho'], 0.05)
        # Tracks of one white error differ only by chance: 10th and 90th percentile of their RMS
        # within 1.5x, the 10 % with the largest RMS hold about 15 % of the squared error.
        spread = s['per_track']
        self.assertGreater(spread['tracks'], 500)
        p10, p50, p90 = spread['rms_percentiles_px']
        self.assertAlmostEqual(p50, 1.0, delta=0.12)
        self.assertLess(p90 / p10, 1.5)
        self.assertLess(spread['worst_10_percent_share'], 0.18)
        # No random walk: the error difference does not grow with the lag.
        self.assertLess(s['random_walk']['rate_px_per_sqrt_s'], 0.5)

    def test_drifting_tracks(self):
        s = self.stats('drift', '--pixel-correlation', 0.85)
        self.assertGreater(s['rho'], 0.75)
        self.assertLess(s['rho'], 0.9)
        for std in s['differenced_std']:
            self.assertLess(std, 0.7)  # sqrt(1 - 0.85^2) = 0.53 for the true rho
        # A slow error wanders further on some tracks than on others: a wider spread than white
        # tracks give (and still far from the KITTI course tracks' 5x).
        spread = s['per_track']
        p10, _, p90 = spread['rms_percentiles_px']
        self.assertGreater(p90 / p10, 1.5)
        self.assertGreater(spread['worst_10_percent_share'], 0.18)
        self.assertGreater(spread['drift_percentiles_px_per_frame'][1], 0.035)
        # AR(1) of 0.85 at 1 px: the difference over L frames has variance 2 (1 - 0.85^L), which
        # grows by 0.26 px^2 per frame at short lags (1.6 px/sqrt(s) at 10 Hz); the fitted
        # landmarks take up a part of it.
        self.assertGreater(s['random_walk']['rate_px_per_sqrt_s'], 1.0)
        self.assertLess(s['random_walk']['rate_px_per_sqrt_s'], 1.8)

    def test_without_ground_truth_the_estimate_reads_the_same_tracks(self):
        # The SLAM trajectory in place of the ground truth (seed 5, 300 frames, measured: white
        # rate 0.29 against 0.08 px/sqrt(s), rho -0.02 against -0.05; AR(1) 0.85 rate 1.61
        # against 1.52, rho 0.77 against 0.79).
        white = self.stats('white_estimated', estimated_poses=True)
        self.assertLess(white['random_walk']['rate_px_per_sqrt_s'], 0.5)
        self.assertLess(abs(white['rho']), 0.1)
        for std in white['std']:
            self.assertAlmostEqual(std, 1.0, delta=0.15)
        drift = self.stats('drift_estimated', '--pixel-correlation', 0.85, estimated_poses=True)
        self.assertGreater(drift['random_walk']['rate_px_per_sqrt_s'], 1.0)
        self.assertLess(drift['random_walk']['rate_px_per_sqrt_s'], 1.8)
        self.assertGreater(drift['rho'], 0.7)
        self.assertLess(drift['rho'], 0.9)

    def test_kitti_poses_read_as_the_tum_file(self):
        """The ground truth as a KITTI poses file (world_T_cam0, a line per frame)."""
        prefix = os.path.join(self.tmp, 'kitti')
        proc = ekf_test_paths.run_script('simulate_dataset.py', '--seed', 5, '--frames', 60,
                                         '--out', prefix)
        self.assertEqual(proc.returncode, 0, proc.stderr)
        with np.load(prefix + '.npz') as data:
            cam_T_imu = data['cam_T_imu']
        _, world_T_imu = trajectory.read_tum(prefix + '_groundtruth.tum')
        kitti = prefix + '_poses.txt'
        world_T_cam0 = np.einsum('nij,jk->nik', world_T_imu, se3.inverse(cam_T_imu))
        np.savetxt(kitti, world_T_cam0[:, :3, :].reshape(-1, 12), fmt='%.12e')
        figures = []
        for poses in (prefix + '_groundtruth.tum', kitti):
            proc = ekf_test_paths.run_script('track_error_stats.py', prefix + '.npz',
                                             '--groundtruth', poses, '--json', prefix + '.json')
            self.assertEqual(proc.returncode, 0, proc.stderr)
            with open(prefix + '.json') as f:
                figures.append(json.load(f))
        np.testing.assert_allclose(figures[1]['std'], figures[0]['std'], rtol=1e-4)
        self.assertAlmostEqual(figures[1]['rho'], figures[0]['rho'], places=4)

    def test_groundtruth_without_matching_stamps_is_refused(self):
        prefix = os.path.join(self.tmp, 'refused')
        proc = ekf_test_paths.run_script('simulate_dataset.py', '--seed', 5, '--frames', 40,
                                         '--out', prefix)
        self.assertEqual(proc.returncode, 0, proc.stderr)
        gt = os.path.join(self.tmp, 'shifted.tum')
        with open(prefix + '_groundtruth.tum') as f, open(gt, 'w') as g:
            for line in f:
                values = line.split()
                g.write(' '.join([str(float(values[0]) + 100.0)] + values[1:]) + '\n')
        proc = ekf_test_paths.run_script('track_error_stats.py', prefix + '.npz',
                                         '--groundtruth', gt)
        self.assertEqual(proc.returncode, 2)
        self.assertEqual(len(proc.stderr.strip().splitlines()), 1)


if __name__ == '__main__':
    unittest.main()
