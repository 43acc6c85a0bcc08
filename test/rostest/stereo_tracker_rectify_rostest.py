#!/usr/bin/python3
"""rostest of raw image input (see stereo_tracker_rectify.test): a rendered drive as the raw
images and camera_info of a calibrated rig (play_stereo_images.py --raw-camera), played into
stereo_vislam.launch with rectify:=true. Every pair is rectified and tracked, predicted from the
twist through the rectified frame's tf, which the tracker publishes (the left camera_info's R);
the features, in that frame, equal track_stereo_bag --rectify's over the same bag bit for bit;
the estimator's odometry ends near the ground truth."""
import os
import sys
import unittest

import numpy as np
import rospy
import rostest
from nav_msgs.msg import Odometry
from tf2_msgs.msg import TFMessage

from ekf_vislam.msg import StereoFeatureArray

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from vislam_rostest import (OneTrackerStatus, log, run, run_script,  # noqa: E402
                            set_up_rendered_drive_test)

from ekf_vislam_tools import raw_camera, se3  # noqa: E402
from ekf_vislam_tools.bag_playback import play_bag, wait_until  # noqa: E402
from ekf_vislam_tools.bag_reading import feature_rows, read_feature_rows  # noqa: E402

PKG = 'ekf_vislam'
FRAMES = 30
PLAY_RATE = 2.0
RAW_IMAGES = ('/stereo/left/image_raw', '/stereo/right/image_raw')
CAMERA_INFOS = ('/stereo/left/camera_info', '/stereo/right/camera_info')
# Measured on this drive (30 pairs, 23 m): the final position error 0.0357 m, as vislam_offline
# gives on track_stereo_bag's features; 0.146 m when the estimator took camera_info's frame, the
# raw camera's, for the features' (fixed). The limit leaves a margin.
FINAL_ERROR_TOLERANCE_M = 0.08


class StereoTrackerRectifyTest(OneTrackerStatus, unittest.TestCase):

    STATUS = 'stereo_tracker'

    @classmethod
    def setUpClass(cls):
        set_up_rendered_drive_test(cls, 'stereo_tracker_rectify_rostest', FRAMES)
        cls.bag = os.path.join(cls.tmp, 'raw.bag')
        run_script('play_stereo_images.py', os.path.join(cls.tmp, 'drive'), '--bag', cls.bag,
                   '--raw-camera')
        cls.features, cls.odometry, cls.groundtruth, cls.static = [], [], [], []
        keep = cls.keep
        listening = [
            rospy.Subscriber('/stereo/features', StereoFeatureArray, keep(cls.features),
                             queue_size=1000),
            rospy.Subscriber('/vislam/odometry', Odometry, keep(cls.odometry), queue_size=1000),
            rospy.Subscriber('/groundtruth/odometry', Odometry, keep(cls.groundtruth),
                             queue_size=1000)]
        rospy.Subscriber('/tf_static', TFMessage, keep(cls.static), queue_size=100)
        manager = ('/stereo_vislam_manager',)
        required = {topic: manager for topic in RAW_IMAGES + CAMERA_INFOS + ('/imu/twist',)}
        play_bag(cls.bag, '/stereo_tracker_rectify_player', PLAY_RATE, required,
                 listening=listening)
        wait_until(lambda: len(cls.features) >= FRAMES and len(cls.odometry) >= FRAMES, 30.0)
        wait_until(lambda: cls.value('pairs_tracked') >= FRAMES, 10.0)

    def test_every_pair_is_rectified_and_predicted_through_the_rectified_frame(self):
        _, values = self.latest_status(self.STATUS)
        self.assertEqual(int(values['pairs_tracked']), FRAMES, values)
        self.assertEqual(int(values['twist_predictions']), FRAMES - 1, values)
        self.assertEqual(int(values['bad_camera_info']), 0, values)
        self.assertGreater(float(values['rectify_ms_last']), 0.0, values)
        self.assertEqual({m.header.frame_id for m in self.features}, {'camera_left_rect'})

    def test_the_rectified_frame_is_turned_by_the_left_r(self):
        transforms = [t for m in self.static for t in m.transforms
                      if t.child_frame_id == 'camera_left_rect']
        self.assertEqual(len({(t.header.frame_id, t.child_frame_id) for t in transforms}), 1)
        t = transforms[-1]
        self.assertEqual(t.header.frame_id, 'camera_left')
        q = t.transform.rotation
        rig = raw_camera.RawStereoCamera(np.eye(3), 0.5, (10, 10))  # R does not depend on K
        raw_R_rect = se3.quaternion_to_rotation([q.x, q.y, q.z, q.w])
        np.testing.assert_allclose(raw_R_rect, rig.raw_T_rectified(0)[:3, :3], atol=1e-9)
        self.assertEqual([t.transform.translation.x, t.transform.translation.y,
                          t.transform.translation.z], [0.0, 0.0, 0.0])

    def test_bag_tool_gives_the_live_features(self):
        tracked = os.path.join(self.tmp, 'tracked.bag')
        log(run(['rosrun', PKG, 'track_stereo_bag', '--bag', self.bag, '--out', tracked,
                 '--rectify']).strip())
        live = [feature_rows(m) for m in self.features[:FRAMES]]
        offline = read_feature_rows(tracked)
        self.assertEqual(len(offline), FRAMES)
        for k, (a, b) in enumerate(zip(live, offline)):
            self.assertEqual(a, b, 'pair %d differs' % k)
        self.assertGreater(sum(len(rows) for _, _, rows in live), 100 * FRAMES)

    def test_odometry_ends_at_the_ground_truth(self):
        truth = {m.header.stamp.to_nsec(): m.pose.pose.position for m in self.groundtruth}
        last = self.odometry[-1]
        expected = truth[last.header.stamp.to_nsec()]
        p = last.pose.pose.position
        error = np.linalg.norm([p.x - expected.x, p.y - expected.y, p.z - expected.z])
        log('final position error %.4f m over %d odometry messages' % (error, len(self.odometry)))
        self.assertLess(error, FINAL_ERROR_TOLERANCE_M)


if __name__ == '__main__':
    rostest.rosrun(PKG, 'stereo_tracker_rectify', StereoTrackerRectifyTest)
