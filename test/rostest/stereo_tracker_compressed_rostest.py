#!/usr/bin/python3
"""rostest of compressed image input (see stereo_tracker_compressed.test): a rendered drive
written as png CompressedImage on the image_transport topics of remapped image topics, its right
stamps 1.5 ms off the left ones, and a last pair whose left image does not decode, played into a
tracker with ros/image_transport compressed: every pair tracked, the raw images' features of
track_stereo_images bit for bit, the bad image counted as undecodable_images. The last pair is
handled though no image follows it: the synchronizer, told that one camera's images lie at least
twice ros/max_stamp_difference apart, emits each pair at once (without that bound it would hold
pairs whose stamps differ until the next image, and never emit the last one)."""
import os
import sys
import unittest

import rosbag
import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticStatus

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from vislam_rostest import (LiveFeatures, OneTrackerStatus, run_script,  # noqa: E402
                            set_up_rendered_drive_test, track_drive_offline)

from ekf_vislam_tools.bag_playback import play_bag, wait_until  # noqa: E402

PKG = 'ekf_vislam'
FRAMES = 30
PLAY_RATE = 2.0
# The tracker's topics (stereo_tracker_compressed.test remaps stereo/ to /cam/).
CAMERA_INFOS = ('/cam/left/camera_info', '/cam/right/camera_info')
COMPRESSED = ('/cam/left/image_rect/compressed', '/cam/right/image_rect/compressed')
# Right stamps this far after (even pairs) or before (odd pairs) the left ones: within the
# tracker's ros/max_stamp_difference (2 ms).
RIGHT_OFFSET_S = 0.0015


def compressed_bag(tmp):
    """The drive (set_up_rendered_drive_test's TMP/drive) as png CompressedImage and camera_info
    on the /cam/ topics, the right stamps RIGHT_OFFSET_S off, then one more pair 0.1 s later (its
    right stamp RIGHT_OFFSET_S later) with a left image that does not decode.
    TMP/compressed.bag."""
    written = os.path.join(tmp, 'drive_png.bag')
    run_script('play_stereo_images.py', os.path.join(tmp, 'drive'), '--bag', written,
               '--compressed', 'png', '--no-twist')
    bag = os.path.join(tmp, 'compressed.bag')
    last, rights = {}, 0
    with rosbag.Bag(written) as src, rosbag.Bag(bag, 'w') as dst:
        for topic, msg, t in src.read_messages():
            topic = topic.replace('/stereo/', '/cam/')
            if topic not in COMPRESSED + CAMERA_INFOS:
                continue
            last[topic] = msg
            if topic == COMPRESSED[1]:
                msg.header.stamp += rospy.Duration(RIGHT_OFFSET_S * (-1) ** rights)
                rights += 1
            dst.write(topic, msg, t)
        stamp = last[COMPRESSED[0]].header.stamp + rospy.Duration(0.1)
        for topic in CAMERA_INFOS + COMPRESSED:
            msg = last[topic]
            msg.header.stamp = stamp
            if topic == COMPRESSED[1]:
                msg.header.stamp += rospy.Duration(RIGHT_OFFSET_S)
            if topic == COMPRESSED[0]:
                msg = type(msg)(header=msg.header, format=msg.format, data=b'not an image')
            dst.write(topic, msg, stamp)
    return bag


class StereoTrackerCompressedTest(LiveFeatures, OneTrackerStatus, unittest.TestCase):

    @classmethod
    def setUpClass(cls):
        set_up_rendered_drive_test(cls, 'stereo_tracker_compressed_rostest', FRAMES)
        bag = compressed_bag(cls.tmp)
        required = {topic: ('/tracker',) for topic in CAMERA_INFOS + COMPRESSED}
        play_bag(bag, '/stereo_tracker_compressed_player', PLAY_RATE, required,
                 listening=[cls.features_subscriber])
        wait_until(lambda: cls.value('undecodable_images') >= 1 and
                   cls.value('pairs_tracked') >= FRAMES, 30.0)
        wait_until(lambda: len(cls.features) >= FRAMES, 10.0)
        cls.offline = os.path.join(cls.tmp, 'offline.npz')
        track_drive_offline(cls.tmp, cls.offline)

    def test_every_pair_is_tracked_and_the_bad_image_counted(self):
        status, values = self.latest_status(self.STATUS)
        self.assertIsNotNone(status)
        self.assertEqual(int(values['undecodable_images']), 1, values)
        self.assertEqual(int(values['pairs_tracked']), FRAMES, values)
        self.assertEqual(int(values['pairs_received']), FRAMES + 1, values)
        self.assertEqual(int(values['unsynchronized']), 0, values)
        self.assertEqual(int(values['pairs_missing']), 0, values)
        self.assertEqual(int(values['bad_encoding']), 0, values)
        self.assertGreater(float(values['decode_ms_last']), 0.0, values)
        self.assertEqual(status.level, DiagnosticStatus.WARN, status.message)

    def test_live_features_are_the_raw_images_offline_features_bit_for_bit(self):
        compared = self.assert_live_features_equal(self.offline, last_may_be_missing=False)
        self.assertGreater(compared, 100 * FRAMES)


if __name__ == '__main__':
    rostest.rosrun(PKG, 'stereo_tracker_compressed', StereoTrackerCompressedTest)
