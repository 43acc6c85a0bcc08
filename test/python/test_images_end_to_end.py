"""The stereo front end and the estimator together on the real KITTI clips (data/kitti_clips;
skipped when absent): scripts/images_end_to_end.sh (track_stereo_images with the accurate twist
of the clip's poses, seed 0, then vislam_offline in SLAM and dead-reckoning modes, then
evaluate.py). Asserts SLAM accuracy and position NEES against the ground truth, within margins
of the figures measured (doc/tracker.md, End to end):

- 01: SLAM ATE 0.0172 m, position NEES 1.85 with the disparity offset corrected from frame 3
  (from frame 10: 0.0322 m, 4.48; not corrected: 0.0594 m, 6.03). Dead reckoning 0.0153 m is
  not asserted against: on seed 0 SLAM stays above it (the issue's target, not met).
- 06 from its frame 12, where its ground truth agrees with its images: SLAM 0.0088 m, NEES
  5.00, below dead reckoning (0.0159 m).
- 06 whole: SLAM 0.0200 m below dead reckoning 0.0236 m. Its NEES (31.94) comes from the ground
  truth's first second, 0.09-0.17 degrees of yaw per frame away from the images, and is not
  asserted."""
import json
import os
import subprocess
import unittest

import ekf_test_paths as paths


def run_end_to_end(testcase, folder, *args):
    """{'slam': (ate_m, nees), 'deadreckoning': (ate_m, nees)} of one images_end_to_end.sh run,
    from the metrics.json evaluate.py writes."""
    out = paths.make_temp_dir(testcase)
    proc = subprocess.run(['bash', os.path.join(paths.SCRIPTS_DIR, 'images_end_to_end.sh'), folder,
                           '--seed', '0', '--out', out] + list(args), stdout=subprocess.PIPE,
                          stderr=subprocess.PIPE, universal_newlines=True, timeout=600)
    testcase.assertEqual(proc.returncode, 0, proc.stderr[-2000:])
    with open(os.path.join(out, 'eval', 'metrics.json')) as f:
        estimates = json.load(f)['estimates']
    figures = {mode: (m['ate_rmse_m'], m['nees_position']['mean'])
               for mode, m in estimates.items()}
    print('%s %s: %s' % (os.path.basename(folder), ' '.join(args), figures))
    testcase.assertEqual(set(figures), {'slam', 'deadreckoning'}, proc.stdout)
    return figures


class ImagesEndToEndTest(unittest.TestCase):

    def clip(self, name):
        folder = paths.data_file('kitti_clips', name)
        if folder is None:
            self.skipTest('kitti_clips/%s not found' % name)
        return folder

    def test_01_with_its_disparity_offset_corrected(self):
        figures = run_end_to_end(self, self.clip('odometry_01_000000-000050'))
        ate, nees = figures['slam']
        self.assertLess(ate, 0.025)
        self.assertLess(nees, 3.5)

    def test_06_from_frame_12_beats_dead_reckoning(self):
        figures = run_end_to_end(self, self.clip('odometry_06_000000-000050'), '--first-frame',
                                 '12')
        ate, nees = figures['slam']
        self.assertLess(ate, figures['deadreckoning'][0])
        self.assertLess(ate, 0.012)
        self.assertLess(nees, 6.5)

    def test_06_beats_dead_reckoning(self):
        figures = run_end_to_end(self, self.clip('odometry_06_000000-000050'))
        self.assertLess(figures['slam'][0], figures['deadreckoning'][0])
        self.assertLess(figures['slam'][0], 0.024)


if __name__ == '__main__':
    unittest.main()
