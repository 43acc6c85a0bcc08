"""scripts/landmark_reference.py: on a simulated drive (true landmarks known) each track,
triangulated from the ground-truth poses, lands near its true landmark, gross outlier observations
left out; the map vislam_offline writes, checked by evaluate.py against that reference, reads a
NEES no larger than against the truth (the lower bound the script documents)."""
import json
import os
import sys
import unittest

import numpy as np

import ekf_test_paths

sys.path.insert(0, ekf_test_paths.SOURCE_DIR)
from ekf_vislam_tools import metrics  # noqa: E402


class LandmarkReferenceTest(unittest.TestCase):

    @classmethod
    def setUpClass(cls):
        cls.tmp, cls.prefix = ekf_test_paths.simulated_drive(cls, '--seed', 3, '--frames', 300)
        # One long track's observation moved by 40 px: the fit must leave it out.
        with np.load(cls.prefix + '.npz') as archive:
            arrays = {key: archive[key] for key in archive.files}
        features = arrays['features']
        seen = features[0] >= 0
        cls.moved_id = int(np.argmax(seen.sum(axis=1)))
        cls.moved_count = int(seen[cls.moved_id].sum())
        frame = np.flatnonzero(seen[cls.moved_id])[cls.moved_count // 2]
        features[0, cls.moved_id, frame] += 40.0
        features[2, cls.moved_id, frame] += 40.0
        cls.npz = cls.prefix + '_moved.npz'
        np.savez(cls.npz, **arrays)
        cls.reference = cls.prefix + '_reference.csv'
        cls.proc = ekf_test_paths.run_script('landmark_reference.py', cls.npz, '--groundtruth',
                                             cls.prefix + '_groundtruth.tum', '--out',
                                             cls.reference)

    def read(self, path):
        return np.genfromtxt(path, delimiter=',', names=True)

    def test_tracks_land_on_their_true_landmarks(self):
        self.assertEqual(self.proc.returncode, 0, self.proc.stderr)
        self.assertIn('ids seen fitted', self.proc.stdout)
        reference = self.read(self.reference)
        truth = {int(row['id']): np.array([row['x'], row['y'], row['z']])
                 for row in self.read(self.prefix + '_landmarks.csv')}
        self.assertGreater(reference.size, 1000)
        errors = np.array([np.linalg.norm([row['x'], row['y'], row['z']] - truth[int(row['id'])])
                           for row in reference])
        long_tracks = reference['observations'] >= 10
        print('reference: %d landmarks, median error %.3f m (%.3f m with 10 observations or more)'
              % (reference.size, np.median(errors), np.median(errors[long_tracks])))
        self.assertLess(np.median(errors[long_tracks]), 0.3)
        moved = reference[reference['id'] == self.moved_id]
        self.assertEqual(moved.size, 1)
        # The moved one left out (and any of the simulator's own gross outliers on that track).
        self.assertLessEqual(int(moved['observations'][0]), self.moved_count - 1)
        self.assertGreater(int(moved['observations'][0]), 0.9 * self.moved_count)
        self.assertLess(errors[reference['id'] == self.moved_id][0], 0.3)

    def test_the_maps_nees_against_it_is_a_lower_bound(self):
        bag = self.prefix + '.bag'
        proc = ekf_test_paths.run_script('dataset_to_bag.py', self.prefix + '.npz', bag)
        self.assertEqual(proc.returncode, 0, proc.stderr)
        run_dir = self.prefix + '_run'
        proc = ekf_test_paths.run_vislam_offline(bag, run_dir)
        self.assertEqual(proc.returncode, 0, proc.stderr)
        landmarks = self.read(os.path.join(run_dir, 'landmarks.csv'))
        self.assertTrue(np.all(landmarks['observations'] >= 2))  # the map: seen twice or more
        nees = {}
        for name, truth in (('reference', self.reference),
                            ('truth', self.prefix + '_landmarks.csv')):
            out = os.path.join(self.tmp, 'evaluate_' + name)
            proc = ekf_test_paths.run_script(
                'evaluate.py', '--estimate', os.path.join(run_dir, 'trajectory.tum'),
                '--groundtruth', self.prefix + '_groundtruth.tum', '--landmarks',
                os.path.join(run_dir, 'landmarks.csv'), '--landmarks-gt', truth, '--out', out)
            self.assertEqual(proc.returncode, 0, proc.stderr)
            self.assertIn('NEES', proc.stdout)
            with open(os.path.join(out, 'metrics.json')) as f:
                result = json.load(f)['estimates']
            nees[name] = list(result.values())[0]['landmark_nees']
        print('map NEES: %.2f against the reference, %.2f against the truth'
              % (nees['reference'], nees['truth']))
        self.assertLess(nees['truth'], 3.0)  # white 1 px tracks, the filter takes 2 px
        self.assertLessEqual(nees['reference'], nees['truth'] * 1.05)

    def test_a_missing_ground_truth_is_one_line(self):
        proc = ekf_test_paths.run_script('landmark_reference.py', self.npz, '--groundtruth',
                                         os.path.join(self.tmp, 'none.tum'), '--out',
                                         os.path.join(self.tmp, 'x.csv'))
        self.assertEqual(proc.returncode, 2)
        self.assertEqual(len(proc.stderr.strip().splitlines()), 1, proc.stderr)
        self.assertIn('none.tum', proc.stderr)


class LandmarkNeesTest(unittest.TestCase):

    def test_nees_is_read_in_the_estimators_gauge(self):
        # The estimate's world is the ground truth's moved by 5 m along x; the trajectory's
        # alignment took out only 4 m of it. Every landmark is 1 sigma off along y in the gauge:
        # NEES 1, error / sigma RMS (0, 1, 0); read after the alignment instead, 1 m along x with
        # a sigma of 0.5 m would add 4.
        gtworld_xyz = np.random.default_rng(1).normal(0, 20, (50, 3))
        gauge = np.eye(4)
        gauge[0, 3] = 5.0  # gtworld_T_estworld
        aligned = np.eye(4)
        aligned[0, 3] = 4.0
        sigma = np.tile([0.5, 2.0, 1.0], (50, 1))
        estworld_xyz = gtworld_xyz - gauge[:3, 3] - [0.0, 2.0, 0.0]
        result = metrics.landmark_errors(np.arange(50), estworld_xyz, np.arange(50), gtworld_xyz,
                                         aligned, sigma, gauge)
        self.assertAlmostEqual(result['landmark_nees'], 1.0, places=9)
        for axis, value in zip('xyz', (0.0, 1.0, 0.0)):
            self.assertAlmostEqual(result['landmark_error_over_sigma_rms'][axis], value,
                                   places=9)
        self.assertAlmostEqual(result['landmark_within_3sigma'], 1.0)
        without = metrics.landmark_errors(np.arange(50), estworld_xyz, np.arange(50),
                                          gtworld_xyz, aligned, sigma)
        self.assertAlmostEqual(without['landmark_nees'], 5.0, places=9)


if __name__ == '__main__':
    unittest.main()
