"""The landmark study's summary (scripts/landmark_study.py): per cell the mean and worst SLAM ATE,
the ratio to dead reckoning, the NEES and the observations that updated the filter per frame; and
the datasets it and scripts/benchmark.py find in a data folder."""
import os
import shutil
import sys
import tempfile
import unittest

import ekf_test_paths as paths

if paths.SCRIPTS_DIR not in sys.path:
    sys.path.insert(0, paths.SCRIPTS_DIR)
import benchmark  # noqa: E402
import landmark_study  # noqa: E402


def result(mode, seed, ate, per_frame=None, nees=None):
    fraction = 1.0 if mode == 'deadreckoning' else 0.05
    return dict(sequence='0027', twist='accurate', fraction=fraction, seed=seed, mode=mode,
                ate_m=ate, observations_per_frame=per_frame, nees_position=nees)


class SummaryTest(unittest.TestCase):
    def test_cells_carry_ratio_nees_and_updates_per_frame(self):
        results = [result('deadreckoning', s, 4.0) for s in (1, 2)]
        results += [result('slam', 1, 2.0, 2.4, 2.0), result('slam', 2, 5.0, 2.6, 4.0)]
        rows, text = landmark_study.summarize(results, ['0027'], [0.05])
        self.assertEqual(len(rows), 1)
        row = rows[0]
        self.assertAlmostEqual(row['slam_ate_mean'], 3.5)
        self.assertAlmostEqual(row['slam_ate_max'], 5.0)
        self.assertAlmostEqual(row['ratio_mean'], 0.875)
        self.assertAlmostEqual(row['ratio_max'], 1.25)
        self.assertAlmostEqual(row['nees_position'], 3.0)
        self.assertAlmostEqual(row['observations_per_frame'], 2.5)
        self.assertIn('updates per frame', text)
        self.assertIn('| 0027 | accurate | 5 % | 2.5 | 3.50 | 5.00 | 4.00 | 0.88 | 1.25 | 3.0 |',
                      text)

    def test_runs_without_the_count_say_so(self):
        results = [result('deadreckoning', 1, 4.0), result('slam', 1, 2.0)]
        rows, text = landmark_study.summarize(results, ['0027'], [0.05])
        self.assertIsNone(rows[0]['observations_per_frame'])
        self.assertIn('| 0027 | accurate | 5 % | - | 2.00 |', text)



class DataFolderTest(unittest.TestCase):
    def test_every_npz_found_those_with_ground_truth_first(self):
        folder = tempfile.mkdtemp(prefix='test_data_folder_')
        self.addCleanup(shutil.rmtree, folder)
        os.makedirs(os.path.join(folder, 'groundtruth'))
        for name in ('a', 'b', 'c', 'd'):
            open(os.path.join(folder, name + '.npz'), 'w').close()
        for name in ('c', 'b'):
            open(os.path.join(folder, 'groundtruth', name + '_imu_gt.tum'), 'w').close()
        open(os.path.join(folder, 'notes.txt'), 'w').close()
        found = benchmark.find_datasets(folder)
        self.assertEqual([name for name, _, _ in found], ['b', 'c', 'a', 'd'])
        self.assertEqual(found[0][1], os.path.join(folder, 'b.npz'))
        self.assertEqual(found[1][2], os.path.join(folder, 'groundtruth', 'c_imu_gt.tum'))
        self.assertEqual([gt is None for _, _, gt in found], [False, False, True, True])
        self.assertEqual(benchmark.find_datasets(os.path.join(folder, 'missing')), [])


if __name__ == '__main__':
    unittest.main()
