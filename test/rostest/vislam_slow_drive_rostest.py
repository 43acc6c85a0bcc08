#!/usr/bin/python3
"""Plays a synthetic drive at walking pace with the course twist's gyro noise through the nodelet:
the node names the regime in /diagnostics (see vislam_slow_drive.test)."""
import os
import sys
import unittest

import rostest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from vislam_rostest import EstimatorStatusCollector  # noqa: E402

PKG = 'ekf_vislam'
FRAMES = 400


class VislamSlowDriveTest(EstimatorStatusCollector, unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        # 0.5-1.5 m/s with 0.05 rad/s of gyro noise per sample (the simulator's default, the
        # course files'): measured position NEES 9.18-17.64 (doc/experiments.md).
        cls.collect_simulated('vislam_slow_drive', 1, FRAMES, '--speed-min', '0.5',
                              '--speed-max', '1.5')

    def test_speed_and_noise_are_reported(self):
        values = self.values(-1)
        self.assertGreater(float(values['twist_mean_speed_m_s']), 0.5)
        self.assertLess(float(values['twist_mean_speed_m_s']), 1.5)
        # 0.05 rad/s per sample at 10 Hz: 0.0158 rad/s/sqrt(Hz), estimated online.
        self.assertAlmostEqual(float(values['twist_angular_noise_density']), 0.0158, delta=0.002)

    def test_status_warns_of_an_optimistic_covariance(self):
        self.assert_warned('slow drive')


if __name__ == '__main__':
    rostest.rosrun(PKG, 'vislam_slow_drive', VislamSlowDriveTest)
