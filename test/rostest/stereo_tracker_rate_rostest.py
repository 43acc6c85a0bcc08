#!/usr/bin/python3
"""rostest of the tracker's rate limit (see stereo_tracker_rate.test): a rendered 10 Hz drive
played into a tracker limited to 4 Hz gives every second pair, counted skips and no fault, and
the features of track_stereo_images run with the same input/max_rate_hz, bit for bit."""
import os
import sys
import unittest

import numpy as np
import rostest
from diagnostic_msgs.msg import DiagnosticStatus

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from vislam_rostest import (LiveFeatures, OneTrackerStatus,  # noqa: E402
                            set_up_rendered_drive_test, stereo_inputs_required,
                            track_drive_offline)

from ekf_vislam_tools.bag_playback import play_bag, wait_until  # noqa: E402

PKG = 'ekf_vislam'
FRAMES = 40
PLAY_RATE = 2.0
MAX_RATE_HZ = 4.0  # input/max_rate_hz in stereo_tracker_rate.test: pairs 0.2 s apart pass
TRACKED = FRAMES // 2  # pairs 0, 2, ..., 38


class StereoTrackerRateTest(LiveFeatures, OneTrackerStatus, unittest.TestCase):

    @classmethod
    def setUpClass(cls):
        bag = set_up_rendered_drive_test(cls, 'stereo_tracker_rate_rostest', FRAMES)
        play_bag(bag, '/stereo_tracker_rate_player', PLAY_RATE,
                 stereo_inputs_required(('/tracker',)), listening=[cls.features_subscriber])
        # The synchronizer emits the last pair (39, not due) only once a later message comes.
        wait_until(lambda: cls.value('pairs_tracked') + cls.value('pairs_skipped_rate') >=
                   FRAMES - 1, 30.0)
        wait_until(lambda: len(cls.features) >= TRACKED, 10.0)
        config = os.path.join(cls.tmp, 'rate.yaml')
        with open(config, 'w') as out:
            out.write('input:\n  max_rate_hz: %g\n' % MAX_RATE_HZ)
        cls.offline = os.path.join(cls.tmp, 'offline.npz')
        track_drive_offline(cls.tmp, cls.offline, ['--config', config])

    def test_every_second_pair_is_tracked_and_the_rest_counted_as_skipped(self):
        status, values = self.latest_status(self.STATUS)
        self.assertEqual(int(values['pairs_tracked']), TRACKED, values)
        self.assertGreaterEqual(int(values['pairs_skipped_rate']), FRAMES - 1 - TRACKED, values)
        self.assertEqual(int(values['pairs_missing']), 0, values)
        self.assertEqual(status.level, DiagnosticStatus.OK, status.message)
        with self.lock:
            stamps = sorted(self.features)
        self.assertEqual(len(stamps), TRACKED)
        np.testing.assert_allclose(np.diff(stamps), 0.2, atol=1e-3)

    def test_live_features_are_the_offline_tools_bit_for_bit(self):
        self.assertEqual(np.load(self.offline)['time_stamps'].size, TRACKED)
        compared = self.assert_live_features_equal(self.offline, last_may_be_missing=False)
        self.assertGreater(compared, 100 * TRACKED)


if __name__ == '__main__':
    rostest.rosrun(PKG, 'stereo_tracker_rate', StereoTrackerRateTest)
