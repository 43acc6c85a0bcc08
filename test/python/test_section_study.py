"""The section study (scripts/section_study.py): how a drive is cut into sections, how many of its
frames the ground truth covers (variants.frames_with_groundtruth), and the summary over seeds
(mean and worst ATE, NEES, the ratio to dead reckoning of the same seed)."""
import sys
import unittest

import numpy as np

import ekf_test_paths as paths

if paths.SCRIPTS_DIR not in sys.path:
    sys.path.insert(0, paths.SCRIPTS_DIR)
import section_study  # noqa: E402

sys.path.insert(0, paths.SOURCE_DIR)
from ekf_vislam_tools import variants  # noqa: E402


def result(mode, seed, ate, nees=None, pose=None, twist='accurate', first=0):
    return dict(sequence='0034', twist=twist, first=first, frames=300, seed=seed, mode=mode,
                ate_m=ate, path_length_m=250.0, nees_position=nees, nees_pose=pose)


class SectionsTest(unittest.TestCase):
    def test_equal_sections_the_last_takes_the_remainder(self):
        self.assertEqual(section_study.sections(1201, 4),
                         [(0, 300), (300, 300), (600, 300), (900, 301)])
        self.assertEqual(section_study.sections(10, 1), [(0, 10)])
        with self.assertRaises(ValueError):
            section_study.sections(7, 4)

    def test_frames_the_groundtruth_covers(self):
        t = np.arange(10, dtype=float) * 0.1 + 5.0
        t_gt = 5.0 + 0.1 * np.arange(7)  # frames 0-6 (t 5.0-5.6) have a pose
        self.assertEqual(variants.frames_with_groundtruth(t, t_gt), 7)
        self.assertEqual(variants.frames_with_groundtruth(t, t_gt[::-1]), 7)  # any order


class SummaryTest(unittest.TestCase):
    def test_rows_over_seeds_with_the_ratio_of_each_seed(self):
        results = [result('slam', 1, 0.2, 2.0, 5.0), result('slam', 2, 0.6, 10.0, 20.0),
                   result('deadreckoning', 1, 0.4, 0.1), result('deadreckoning', 2, 0.3, 0.3),
                   result('slam', 1, 1.0, 6.0, 9.0, twist='course', first=300),
                   result('deadreckoning', 1, 4.0, 1.0, twist='course', first=300)]
        rows, text = section_study.summarize(results)
        self.assertEqual([(r['twist'], r['first']) for r in rows],
                         [('course', 300), ('accurate', 0)])
        accurate = rows[1]
        self.assertAlmostEqual(accurate['slam_ate_mean'], 0.4)
        self.assertAlmostEqual(accurate['slam_ate_max'], 0.6)
        self.assertAlmostEqual(accurate['ratio_mean'], 1.25)  # 0.5 and 2.0
        self.assertAlmostEqual(accurate['ratio_max'], 2.0)
        self.assertAlmostEqual(accurate['nees_position'], 6.0)
        self.assertAlmostEqual(accurate['nees_position_max'], 10.0)
        self.assertAlmostEqual(accurate['nees_pose_max'], 20.0)
        self.assertAlmostEqual(accurate['dr_nees_position'], 0.2)
        self.assertIn('| 0034 | course | 300-599 | 250 | 1 | 1.000 | 1.000 | 4.000 | 0.25 |',
                      text)


if __name__ == '__main__':
    unittest.main()
