#!/usr/bin/python3
"""Plays a simulated drive whose stereo features come from swapped images through the nodelet:
the node names the swap in /diagnostics (see vislam_feature_geometry.test)."""
import os
import sys
import unittest

import numpy as np
import rospy
import rostest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from vislam_rostest import EstimatorStatusCollector, run_script, simulated_drive  # noqa: E402

PKG = 'ekf_vislam'
FRAMES = 150
SUMMARY = 'most stereo features rejected'


def swapped_bag(prefix):
    """A simulated drive (seed 3) with u_left and u_right exchanged, as PREFIX.bag."""
    simulated_drive(prefix, 3, FRAMES)
    with np.load(prefix + '.npz') as data:
        arrays = {key: data[key] for key in data.files}
    features = arrays['features'].copy()
    seen = features[0] >= 0
    features[0][seen], features[2][seen] = arrays['features'][2][seen], arrays['features'][0][seen]
    arrays['features'] = features
    np.savez(prefix + '_swapped.npz', **arrays)
    run_script('dataset_to_bag.py', prefix + '_swapped.npz', prefix + '.bag')
    return prefix + '.bag'


class VislamFeatureGeometryTest(EstimatorStatusCollector, unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.collect_from('vislam_feature_geometry', FRAMES, swapped_bag)

    def test_swapped_features_are_rejected_and_named(self):
        values = self.values(-1)
        rejected = int(values['observation_disparity'])
        used = int(values['observation_update']) + int(values['observation_initialized'])
        rospy.loginfo('observation_disparity %d, used %d, summary "%s"', rejected, used,
                      self.statuses[-1].message)
        self.assertGreater(rejected, 3000)
        # Only the few outliers of the drive (gross mismatches) come out with a positive disparity.
        self.assertLess(used, 0.05 * rejected)
        self.assert_warned(SUMMARY)


if __name__ == '__main__':
    rostest.rosrun(PKG, 'vislam_feature_geometry', VislamFeatureGeometryTest)
