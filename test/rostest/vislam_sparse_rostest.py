#!/usr/bin/python3
"""Plays a synthetic drive with about 3 tracked features per frame through the nodelet: the node
names the sparse regime in /diagnostics (see vislam_sparse.test)."""
import os
import shutil
import sys
import tempfile
import unittest

import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticStatus

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from vislam_rostest import EstimatorStatusCollector, simulated_bag  # noqa: E402

PKG = 'ekf_vislam'
FRAMES = 300


class VislamSparseTest(EstimatorStatusCollector, unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node('vislam_sparse_rostest', anonymous=True)
        cls.tmp = tempfile.mkdtemp(prefix='ekf_vislam_sparse_')
        bag = simulated_bag(os.path.join(cls.tmp, 'sparse'), 6, FRAMES, '--target-obs', '3')
        cls.play_and_collect(bag, '/vislam_sparse_player', FRAMES)

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.tmp, ignore_errors=True)

    def test_observations_per_frame_are_reported(self):
        per_frame = float(self.values(-1)['observations_per_frame'])
        self.assertGreater(per_frame, 0.5)
        self.assertLess(per_frame, 8.0)

    def test_status_warns_of_an_optimistic_covariance(self):
        warned = [s for s in self.statuses if 'few observations per frame' in s.message]
        self.assertTrue(warned, [s.message for s in self.statuses])
        self.assertTrue(all(s.level == DiagnosticStatus.WARN for s in warned))


if __name__ == '__main__':
    rostest.rosrun(PKG, 'vislam_sparse', VislamSparseTest)
