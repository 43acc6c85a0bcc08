#!/usr/bin/python3
"""Plays a synthetic drive with about 3 tracked features per frame through the nodelet: the node
names the sparse regime in /diagnostics (see vislam_sparse.test)."""
import os
import sys
import unittest

import rostest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from vislam_rostest import EstimatorStatusCollector  # noqa: E402

PKG = 'ekf_vislam'
FRAMES = 300


class VislamSparseTest(EstimatorStatusCollector, unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.collect_simulated('vislam_sparse', 6, FRAMES, '--target-obs', '3')

    def test_observations_per_frame_are_reported(self):
        per_frame = float(self.values(-1)['observations_per_frame'])
        self.assertGreater(per_frame, 0.5)
        self.assertLess(per_frame, 8.0)

    def test_status_warns_of_an_optimistic_covariance(self):
        self.assert_warned('few observations per frame')


if __name__ == '__main__':
    rostest.rosrun(PKG, 'vislam_sparse', VislamSparseTest)
