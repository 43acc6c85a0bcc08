#!/usr/bin/python3
"""rostest of the tracker's stereo rig check (see stereo_rig_check.test): a short rendered drive
played into a tracker that gets its images as recorded and one that gets them swapped; only the
second's diagnostics name the swap."""
import os
import shutil
import sys
import tempfile
import threading
import unittest

import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticStatus

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from vislam_rostest import (NewestStatuses, log, rendered_drive_bag,  # noqa: E402
                            stereo_inputs_required)

from ekf_vislam_tools.bag_playback import play_bag, wait_until  # noqa: E402

PKG = 'ekf_vislam'
FRAMES = 20
PLAY_RATE = 1.0


class StereoRigCheckTest(NewestStatuses, unittest.TestCase):

    @classmethod
    def setUpClass(cls):
        rospy.init_node('stereo_rig_check_rostest', anonymous=True)
        cls.tmp = tempfile.mkdtemp(prefix='ekf_vislam_rig_check_')
        bag = rendered_drive_bag(cls.tmp, FRAMES)
        cls.lock = threading.Lock()
        cls.listen_to_diagnostics()
        required = stereo_inputs_required(('/tracker_as_recorded', '/swapped/tracker_swapped'))
        play_bag(bag, '/stereo_rig_check_player', PLAY_RATE, required)

        def tracked_everything():
            return all(int(cls.values(name).get('pairs_tracked', 0)) >= FRAMES - 1
                       for name in ('tracker_as_recorded', 'tracker_swapped'))
        wait_until(tracked_everything, 30.0)
        wait_until(lambda: 'swapped' in cls.message('tracker_swapped'), 5.0)

    @classmethod
    def status(cls, name_part):
        return cls.latest_status(name_part)[0]

    @classmethod
    def values(cls, name_part):
        return cls.latest_status(name_part)[1]

    @classmethod
    def message(cls, name_part):
        status = cls.status(name_part)
        return status.message if status else ''

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.tmp, ignore_errors=True)

    def test_swapped_images_are_named(self):
        swapped, recorded = self.values('tracker_swapped'), self.values('tracker_as_recorded')
        log('swapped: "%s" %s; as recorded: "%s" %s' % (
            self.message('tracker_swapped'),
            {k: v for k, v in swapped.items() if k.startswith(('stereo_row', 'stereo_neg'))},
            self.message('tracker_as_recorded'),
            {k: v for k, v in recorded.items() if k.startswith(('stereo_row', 'stereo_neg'))}))
        self.assertIn('swapped', self.message('tracker_swapped'))
        self.assertEqual(self.status('tracker_swapped').level, DiagnosticStatus.WARN)
        self.assertGreater(float(swapped['stereo_negative_disparity_fraction']), 0.9)
        self.assertEqual(self.status('tracker_as_recorded').level, DiagnosticStatus.OK)
        self.assertLess(float(recorded['stereo_negative_disparity_fraction']), 0.05)
        self.assertLess(float(recorded['stereo_row_failed_fraction']), 0.1)
        self.assertLess(abs(float(recorded['stereo_row_offset_px'])), 0.2)


if __name__ == '__main__':
    rostest.rosrun(PKG, 'stereo_rig_check', StereoRigCheckTest)
