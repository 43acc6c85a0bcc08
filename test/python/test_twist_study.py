"""The twist study (scripts/twist_study.py): how a twist is named, what make_variant is asked for
it, and the summary over seeds in the order the twists were asked."""
import sys
import unittest

import ekf_test_paths as paths

if paths.SCRIPTS_DIR not in sys.path:
    sys.path.insert(0, paths.SCRIPTS_DIR)
import twist_study  # noqa: E402


def result(mode, seed, ate, nees=None, pose=None, twist='0.5,0.2,0.009'):
    return dict(sequence='0027', twist=twist, seed=seed, mode=mode, ate_m=ate,
                path_length_m=692.0, nees_position=nees, nees_pose=pose)


class TwistNamesTest(unittest.TestCase):
    def test_course_or_three_numbers(self):
        self.assertIsNone(twist_study.parse_twist('course'))
        self.assertEqual(twist_study.parse_twist('0.5,0.2,0.009'), (0.5, 0.2, 0.009))
        for bad in ('0.5,0.2', '0.5,x,0.1', '0.5,-0.2,0.1', 'accurate', ''):
            with self.assertRaises(ValueError):
                twist_study.parse_twist(bad)
        for twist in twist_study.DEFAULT_TWISTS:
            twist_study.parse_twist(twist)

    def test_variant_arguments(self):
        self.assertEqual(twist_study.variant_arguments('course'), dict(twist='course'))
        self.assertEqual(twist_study.variant_arguments('1.0,0.1,0.009'),
                         dict(twist='accurate', twist_noise=(1.0, 0.1), gyro_offset=0.009))


class SummaryTest(unittest.TestCase):
    def test_rows_in_the_order_asked_over_seeds(self):
        results = [result('slam', 1, 2.0, 1.0, 4.0), result('slam', 2, 3.0, 27.0, 40.0),
                   result('deadreckoning', 1, 40.0, 2.0), result('deadreckoning', 2, 60.0, 3.0),
                   result('slam', 1, 2.006, 1.77, 3.9, twist='course'),
                   result('deadreckoning', 1, 15.959, 0.3, twist='course'),
                   result('slam', 1, 9.0, 1.0, 2.0, twist='2.0,0.05,0.009')]  # no dead reckoning
        rows, text = twist_study.summarize(results, ['course', '0.5,0.2,0.009', '2.0,0.05,0.009'])
        self.assertEqual([r['twist'] for r in rows], ['course', '0.5,0.2,0.009'])
        noisy = rows[1]
        self.assertAlmostEqual(noisy['slam_ate_mean'], 2.5)
        self.assertAlmostEqual(noisy['ratio_mean'], 0.05)  # 2 / 40 and 3 / 60
        self.assertAlmostEqual(noisy['nees_position'], 14.0)
        self.assertAlmostEqual(noisy['nees_position_max'], 27.0)
        self.assertAlmostEqual(noisy['dr_nees_position'], 2.5)
        self.assertIn('| 0027 | 0.5 / 0.2 / 0.009 | 692 | 2 | 2.500 | 3.000 | 50.000 | 0.05 |', text)
        self.assertIn('| 0027 | course | 692 | 1 | 2.006 |', text)


if __name__ == '__main__':
    unittest.main()
