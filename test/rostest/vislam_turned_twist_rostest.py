#!/usr/bin/python3
"""Plays a synthetic drive whose twist turns the other way than the camera tf through the nodelet:
the node names the contradiction in /diagnostics (see vislam_turned_twist.test)."""
import os
import sys
import unittest

import numpy as np
import rostest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from vislam_rostest import EstimatorStatusCollector, run_script, simulated_drive  # noqa: E402

from ekf_vislam_tools.twist_axes import HALF_TURN_X  # noqa: E402

PKG = 'ekf_vislam'
FRAMES = 300


def turned_twist_bag(prefix):
    """A simulated drive (seed 3) with its twist in axes turned by a half turn about x, kept so
    in the bag (dataset_to_bag.py would otherwise turn it back)."""
    simulated_drive(prefix, 3, FRAMES)
    with np.load(prefix + '.npz') as data:
        arrays = {key: data[key] for key in data.files}
    for key in ('linear_velocity', 'rotational_velocity'):
        arrays[key] = HALF_TURN_X @ arrays[key]
    np.savez(prefix + '_turned.npz', **arrays)
    run_script('dataset_to_bag.py', prefix + '_turned.npz', prefix + '_turned.bag',
               '--groundtruth', prefix + '_groundtruth.tum', '--no-fix-twist-axes')
    return prefix + '_turned.bag'


class VislamTurnedTwistTest(EstimatorStatusCollector, unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.collect_from('vislam_turned_twist', FRAMES, turned_twist_bag)

    def test_the_prediction_was_widened_in_many_frames(self):
        # vislam_offline on this drive: 64 of 300 frames widened, 1.2 % of the observations gated.
        self.assertGreater(int(self.values(-1)['frame_prediction_widened']), 30)

    def test_status_warns_that_the_inputs_contradict_each_other(self):
        self.assert_warned('the prediction disagreed with the images')


if __name__ == '__main__':
    rostest.rosrun(PKG, 'vislam_turned_twist', VislamTurnedTwistTest)
