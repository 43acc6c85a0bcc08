#!/usr/bin/python3
"""Plays a synthetic drive whose disparities are all 1 px too large through the nodelet: the node
reads the offset from the observations and names it in /diagnostics (see
vislam_disparity_offset.test)."""
import os
import sys
import unittest

import rostest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from vislam_rostest import EstimatorStatusCollector  # noqa: E402

PKG = 'ekf_vislam'
FRAMES = 600  # long enough for the reading's white sigma to reach 0.025 px and be counted
OFFSET_PX = 1.0  # measured minus true disparity


class VislamDisparityOffsetTest(EstimatorStatusCollector, unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        # A good twist (0.05 m/s and 0.005 rad/s per sample, a 0.001 rad/s gyro offset); every
        # u_right OFFSET_PX to the left.
        cls.collect_simulated('vislam_disparity_offset', 2, FRAMES, '--disparity-offset', OFFSET_PX,
                              '--velocity-noise', 0.05, '--gyro-noise', 0.005, '--gyro-bias',
                              0.001)

    def test_the_offset_is_read_and_counted(self):
        values = self.values(-1)
        self.assertAlmostEqual(float(values['disparity_offset_shown_px']), OFFSET_PX, delta=0.2)
        self.assertGreater(float(values['disparity_offset_sigma_px']), 0.6)  # configured: 0.1

    def test_status_warns_of_the_offset(self):
        self.assert_warned('the stereo disparities err')


if __name__ == '__main__':
    rostest.rosrun(PKG, 'vislam_disparity_offset', VislamDisparityOffsetTest)
