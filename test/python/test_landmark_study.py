"""The landmark study's summary (scripts/landmark_study.py): per cell the mean and worst SLAM ATE,
the ratio to dead reckoning, the NEES and the observations that updated the filter per frame."""
import sys
import unittest

import ekf_test_paths as paths

if paths.SCRIPTS_DIR not in sys.path:
    sys.path.insert(0, paths.SCRIPTS_DIR)
import landmark_study  # noqa: E402


def result(mode, seed, ate, per_frame=None, nees=None):
    fraction = 1.0 if mode == 'deadreckoning' else 0.05
    return dict(sequence='0027', twist='accurate', fraction=fraction, seed=seed, mode=mode,
                ate_m=ate, observations_per_frame=per_frame, nees_position=nees)


class SummaryTest(unittest.TestCase):
    def test_cells_carry_ratio_nees_and_updates_per_frame(self):
        results = [result('deadreckoning', s, 4.0) for s in (1, 2)]
        results += [result('slam', 1, 2.0, 2.4, 2.0), result('slam', 2, 5.0, 2.6, 4.0)]
        rows, text = landmark_study.summarize(results, [0.05])
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
        rows, text = landmark_study.summarize(results, [0.05])
        self.assertIsNone(rows[0]['observations_per_frame'])
        self.assertIn('| 0027 | accurate | 5 % | - | 2.00 |', text)


if __name__ == '__main__':
    unittest.main()
