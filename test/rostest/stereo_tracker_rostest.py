#!/usr/bin/python3
"""rostest of the stereo front end (see stereo_tracker.test): renders a short synthetic stereo
drive (render_stereo_drive.py), writes it as a bag of images, camera_info, twist and ground truth
(play_stereo_images.py --bag), plays it into launch/stereo_vislam.launch and checks the tracker's
features (count, stamps, frame, persistent ids, positive disparity, same rows), that
track_stereo_bag over the same bag gives them bit for bit, the estimator's odometry against the
ground truth, then bad input in the tracker's diagnostics and a 12-bit camera's mono16 pair
taken."""
import os
import shutil
import sys
import tempfile
import threading
import time
import unittest

import numpy as np
import rosbag
import rospy
import rostest
from nav_msgs.msg import Odometry
from sensor_msgs.msg import CameraInfo, Image

from ekf_vislam.msg import StereoFeatureArray

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from vislam_rostest import (DelayedRelay, NewestStatuses, log, rendered_drive_bag, run,  # noqa: E402
                            stereo_inputs_required)

from ekf_vislam_tools.bag_playback import play_bag, wait_until  # noqa: E402
from ekf_vislam_tools.bag_reading import feature_rows, read_feature_rows  # noqa: E402

PKG = 'ekf_vislam'
FRAMES = 80
PLAY_RATE = 2.0
# Measured on this drive (80 frames, 63 m) with config/default.yaml: 80 feature messages, mean
# track length 5.10, final position error 0.061 m (the shipped twist noise is that of a noisy
# twist, this drive's twist is accurate); the limits leave a margin.
MIN_FEATURES = 100
MIN_MEAN_TRACK_LENGTH = 4.0
FINAL_ERROR_TOLERANCE_M = 0.5
# The masked tracker's mask (stereo_tracker.test): rows from this one on are masked.
MASKED_FROM_ROW = 144
# Wall seconds the twist stream is held back in the replay: 6 s of message time at PLAY_RATE,
# beyond the tracker's ros/max_twist_wait (5 s in stereo_tracker.test), which a pair waits for it
# in message time, and within the 5 s it waits in wall time too (2 s to spare for a loaded
# machine, where the relay in this test node may itself be late).
REPLAY_TWIST_DELAY_S = 3.0


class StereoTrackerPipelineTest(NewestStatuses, unittest.TestCase):

    @classmethod
    def setUpClass(cls):
        rospy.init_node('stereo_tracker_rostest', anonymous=True)
        cls.tmp = tempfile.mkdtemp(prefix='ekf_vislam_tracker_rostest_')
        cls.bag = rendered_drive_bag(cls.tmp, FRAMES)
        cls.lock = threading.Lock()
        cls.features, cls.odometry, cls.groundtruth, cls.images = [], [], [], []
        cls.masked_features = []
        # Counted outputs: connected before the bag plays (play_bag's listening).
        counted = [
            rospy.Subscriber('/stereo/features', StereoFeatureArray, cls.keep(cls.features),
                             queue_size=1000),
            rospy.Subscriber('/masked/stereo/features', StereoFeatureArray,
                             cls.keep(cls.masked_features), queue_size=1000),
            rospy.Subscriber('/vislam/odometry', Odometry, cls.keep(cls.odometry),
                             queue_size=1000),
            rospy.Subscriber('/groundtruth/odometry', Odometry, cls.keep(cls.groundtruth),
                             queue_size=1000)]
        rospy.Subscriber('/stereo/left/image_rect', Image,
                         lambda m: cls.images.append(m.header.stamp), queue_size=1000)
        cls.listen_to_diagnostics()
        # Played once the tracker and the estimator (one manager) and this test are connected.
        manager = ('/stereo_vislam_manager',)
        both = manager + ('/masked/tracker_with_mask',)
        required = stereo_inputs_required(both)
        required['/imu/twist'] = manager
        required['/stereo/left/image_rect'] = both + (rospy.get_name(),)
        cls.required = required
        play_bag(cls.bag, '/stereo_tracker_rostest_player', PLAY_RATE, required,
                 listening=counted)
        cls.wait_for_last_image()

    @classmethod
    def wait_for_last_image(cls, odometry_from=0, features_from=0):
        """On a loaded machine the tracker and the estimator lag behind the bag: waits until the
        estimator's odometry (from index odometry_from on) has reached the last image and the
        tracker has published a feature message per pair (from index features_from on; the
        odometry comes at twist rate, so it can reach the last image while the tracker still
        works on the last pairs). A pair that never comes out shows as the count's shortfall."""
        wait_until(lambda: cls.images and len(cls.odometry) > odometry_from and
                   cls.odometry[-1].header.stamp >= max(cls.images) and
                   len(cls.features) - features_from >= FRAMES, 60.0)
        time.sleep(1.0)

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.tmp, ignore_errors=True)

    def test_01_features(self):
        features = list(self.features)
        log('%d feature messages, %d images' % (len(features), len(self.images)))
        # A pair late for any reason waits; should one go missing, say where it went.
        _, tracker = self.latest_status('stereo_tracker')
        unanswered = sorted(set(s.to_sec() for s in self.images) -
                            set(m.header.stamp.to_sec() for m in features))
        self.assertEqual(len(features), FRAMES, 'images without features at %s; tracker '
                         'diagnostics: %s' % (unanswered, sorted(
                             (k, v) for k, v in tracker.items()
                             if k.startswith(('pairs', 'images', 'frames')))))
        self.assertEqual(tracker.get('pairs_missing'), '0')
        image_stamps = set(s.to_nsec() for s in self.images)
        ids_seen = {}
        for msg in features:
            self.assertEqual(msg.header.frame_id, 'camera_left')
            self.assertIn(msg.header.stamp.to_nsec(), image_stamps)
            self.assertGreaterEqual(len(msg.features), MIN_FEATURES)
            for f in msg.features:
                self.assertGreater(f.u_left - f.u_right, 0.0)
                self.assertLess(abs(f.v_left - f.v_right), 1.01)
                ids_seen[f.id] = ids_seen.get(f.id, 0) + 1
        lengths = np.array(list(ids_seen.values()))
        log('%d ids, mean track length %.2f' % (len(lengths), lengths.mean()))
        self.assertGreater(lengths.mean(), MIN_MEAN_TRACK_LENGTH)
        self.assertGreater(np.sum(lengths >= 10), 50)

    def test_01b_mask_keeps_features_off_masked_rows(self):
        # The masked tracker takes the same pairs; it may still be at work on the last ones.
        wait_until(lambda: len(self.masked_features) >= FRAMES, 60.0)
        masked = list(self.masked_features)[:FRAMES]
        unmasked = [f for msg in list(self.features) for f in msg.features]
        rows = np.array([f.v_left for msg in masked for f in msg.features])
        log('masked tracker: %d feature messages, %d features (%d in the masked rows); the '
            'unmasked one: %d of %d there' % (
                len(masked), len(rows), np.sum(np.round(rows) >= MASKED_FROM_ROW),
                sum(round(f.v_left) >= MASKED_FROM_ROW for f in unmasked), len(unmasked)))
        self.assertEqual(len(masked), FRAMES)
        self.assertGreater(sum(round(f.v_left) >= MASKED_FROM_ROW for f in unmasked), 1000)
        self.assertGreater(len(rows), 0.4 * len(unmasked))
        self.assertEqual(int(np.sum(np.round(rows) >= MASKED_FROM_ROW)), 0)

    def test_01c_bag_tool_gives_the_live_features_and_odometry(self):
        # track_stereo_bag over the bag just played: the live tracker's features, bit for bit,
        # and vislam_offline on its output bag a trajectory to the ground truth.
        tracked = os.path.join(self.tmp, 'tracked.bag')
        log(run(['rosrun', PKG, 'track_stereo_bag', '--bag', self.bag, '--out', tracked]).strip())
        live = [feature_rows(m) for m in list(self.features)[:FRAMES]]
        offline = read_feature_rows(tracked)
        with rosbag.Bag(tracked) as bag:
            self.assertEqual(bag.get_message_count('/stereo/left/image_rect'), 0)
            self.assertEqual(bag.get_message_count('/imu/twist'), FRAMES)
        self.assertEqual(len(offline), FRAMES)
        for k, (a, b) in enumerate(zip(live, offline)):
            self.assertEqual(a, b, 'pair %d differs' % k)
        out = os.path.join(self.tmp, 'offline')
        run(['rosrun', PKG, 'vislam_offline', '--bag', tracked, '--out', out])
        trajectory = np.loadtxt(os.path.join(out, 'trajectory.tum'))
        self.assertEqual(trajectory.shape[0], FRAMES)
        truth = {m.header.stamp.to_nsec(): m.pose.pose.position for m in self.groundtruth}
        last = truth[live[-1][0]]
        error = np.linalg.norm(trajectory[-1, 1:4] - [last.x, last.y, last.z])
        log('track_stereo_bag + vislam_offline: final position error %.3f m' % error)
        self.assertLess(error, FINAL_ERROR_TOLERANCE_M)

    def test_02_odometry(self):
        self.assertGreaterEqual(len(self.odometry), FRAMES - 2)
        gt = {m.header.stamp.to_nsec(): m.pose.pose.position for m in self.groundtruth}
        last = self.odometry[-1]
        truth = gt[last.header.stamp.to_nsec()]
        p = last.pose.pose.position
        error = np.linalg.norm([p.x - truth.x, p.y - truth.y, p.z - truth.z])
        log('final position error %.3f m after %.1f m' % (error, np.hypot(truth.x, truth.y)))
        self.assertTrue(np.all(np.isfinite([p.x, p.y, p.z])))
        self.assertLess(error, FINAL_ERROR_TOLERANCE_M)

    def test_03_bad_input_is_counted(self):
        left = rospy.Publisher('/stereo/left/image_rect', Image, queue_size=10)
        right = rospy.Publisher('/stereo/right/image_rect', Image, queue_size=10)
        time.sleep(1.0)
        stamp = rospy.Time(5000.0)

        def image(width, encoding, t, depth=1, pixel=b'\x00'):
            msg = Image()
            msg.header.stamp, msg.header.frame_id = t, 'camera_left'
            msg.width, msg.height, msg.encoding = width, 192, encoding
            msg.step = width * depth
            msg.data = pixel * (msg.step * msg.height // depth)
            return msg
        # A 32-bit float image is refused; a 12-bit camera's mono16 pair (every value 4095,
        # little-endian) is taken, its 12 significant bits read from the images.
        depths, pixels = {'32FC1': 4, 'mono16': 2}, {'mono16': b'\xff\x0f'}
        for k, (lw, rw, enc, dt) in enumerate([(640, 640, '32FC1', 0.0), (640, 320, 'mono8', 0.0),
                                                (640, 640, 'mono8', 0.05),
                                                (640, 640, 'mono16', 0.0),
                                                # ApproximateTime emits a pair once later
                                                # messages arrive: two more, in step.
                                                (640, 640, 'mono8', 0.0), (640, 640, 'mono8', 0.0)]):
            t = stamp + rospy.Duration(k)
            depth, pixel = depths.get(enc, 1), pixels.get(enc, b'\x00')
            left.publish(image(lw, enc, t, depth, pixel))
            right.publish(image(rw, enc, t + rospy.Duration(dt), depth, pixel))
            time.sleep(0.3)

        def counters():
            return self.latest_status('stereo_tracker')[1]
        # The jump from the drive's stamps to 5000 s counts as pairs missing (a paused stream).
        ok = wait_until(lambda: all(int(counters().get(k, 0)) >= 1 for k in
                                    ('bad_encoding', 'size_mismatch', 'unsynchronized',
                                     'pairs_missing')), 10.0)
        log('tracker diagnostics: %s' % counters())
        self.assertTrue(ok)
        # The masked tracker, which does not wait for the twist, tracks the black mono8 pairs:
        # no feature, counted and said.
        ok = wait_until(lambda: int(self.latest_status('tracker_with_mask')[1].get(
            'pairs_without_features', 0)) >= 1, 10.0)
        status, values = self.latest_status('tracker_with_mask')
        log('masked tracker: %s, pairs_without_features %s, image_bits %s' % (
            status.message, values.get('pairs_without_features'), values.get('image_bits')))
        self.assertTrue(ok)
        ok = wait_until(lambda: self.latest_status('tracker_with_mask')[1].get('image_bits') ==
                        '12', 10.0)
        self.assertTrue(ok, self.latest_status('tracker_with_mask')[1])

    def test_04_missing_camera_info_is_counted(self):
        # The second tracker (stereo_tracker.test, namespace nocalib) never gets camera_info and
        # holds 3 waiting pairs: of 6 pairs, the oldest 3 are dropped and counted.
        left = rospy.Publisher('/nocalib/stereo/left/image_rect', Image, queue_size=10)
        right = rospy.Publisher('/nocalib/stereo/right/image_rect', Image, queue_size=10)
        wait_until(lambda: left.get_num_connections() > 0 and right.get_num_connections() > 0,
                   10.0)
        time.sleep(0.5)
        for k in range(7):  # ApproximateTime emits a pair once a later one arrives
            for publisher in (left, right):
                msg = Image()
                msg.header.stamp, msg.header.frame_id = rospy.Time(6000.0 + k), 'camera_left'
                msg.width, msg.height, msg.encoding, msg.step = 640, 192, 'mono8', 640
                msg.data = bytes(640 * 192)
                publisher.publish(msg)
            time.sleep(0.3)

        def counted():
            values = self.latest_status('without_camera_info')[1]
            return (int(values.get('missing_camera_info', 0)) >= 3
                    and int(values.get('pairs_dropped_waiting', 0)) >= 3)
        ok = wait_until(counted, 10.0)
        status, values = self.latest_status('without_camera_info')
        log('tracker without camera_info: %s, %s' % (status.message if status else None, values))
        self.assertTrue(ok)
        self.assertIn('camera_info', status.message)
        self.assertEqual(status.level, 2)  # ERROR: nothing can be tracked
        self.assertEqual(values['pairs_tracked'], '0')
        self.assertEqual(values['pairs_waiting'], '3')

    def test_04b_unrectified_camera_info_is_refused(self):
        # Then the second tracker gets a camera_info pair whose principal points differ by half a
        # pixel (not a rectified pair, which the estimator refuses too): its 3 waiting pairs are
        # refused and counted, and none is tracked.
        infos = []
        for side, cx in (('left', 320.0), ('right', 320.5)):
            info = CameraInfo()
            info.header.frame_id = 'camera_' + side
            info.width, info.height = 640, 192
            tx = -300.0 * 0.5 if side == 'right' else 0.0
            info.P = [300.0, 0.0, cx, tx, 0.0, 300.0, 96.0, 0.0, 0.0, 0.0, 1.0, 0.0]
            publisher = rospy.Publisher('/nocalib/stereo/%s/camera_info' % side, CameraInfo,
                                        queue_size=1, latch=True)
            infos.append(publisher)
            publisher.publish(info)

        def refused():
            return int(self.latest_status('without_camera_info')[1].get('bad_camera_info', 0)) >= 3
        ok = wait_until(refused, 10.0)
        status, values = self.latest_status('without_camera_info')
        log('tracker with a camera_info pair not rectified: %s, %s' % (
            status.message if status else None, values))
        self.assertTrue(ok)
        self.assertEqual(values['pairs_tracked'], '0')
        self.assertEqual(values['pairs_waiting'], '0')
        self.assertEqual(status.level, 2)  # ERROR: no pair tracked

    def test_04c_new_calibration_continues_the_ids(self):
        """The second tracker then gets a rectified camera_info pair and textured pairs, then
        another calibration (fx 300 -> 310) and more pairs: the tracker built for the new
        calibration numbers its tracks on from the first one's, never reusing an id."""
        features = []
        rospy.Subscriber('/nocalib/stereo/features', StereoFeatureArray, features.append,
                         queue_size=100)
        left = rospy.Publisher('/nocalib/stereo/left/image_rect', Image, queue_size=10)
        right = rospy.Publisher('/nocalib/stereo/right/image_rect', Image, queue_size=10)
        infos = [rospy.Publisher('/nocalib/stereo/%s/camera_info' % side, CameraInfo,
                                 queue_size=1, latch=True) for side in ('left', 'right')]
        rng = np.random.default_rng(7)
        texture = rng.integers(0, 256, size=(196, 660)).astype(float)
        texture = sum(np.roll(np.roll(texture, dy, 0), dx, 1)
                      for dy in (-1, 0, 1) for dx in (-1, 0, 1)) / 9.0

        def play(fx, first_stamp):
            for side, publisher in zip(('left', 'right'), infos):
                info = CameraInfo()
                info.header.frame_id = 'camera_' + side
                info.width, info.height = 640, 192
                tx = -fx * 0.5 if side == 'right' else 0.0
                info.P = [fx, 0.0, 320.0, tx, 0.0, fx, 96.0, 0.0, 0.0, 0.0, 1.0, 0.0]
                publisher.publish(info)
            time.sleep(0.5)
            for k in range(6):  # the scene moves 2 px left per pair, 8 px of disparity
                for publisher, column in ((left, 2 * k), (right, 2 * k + 8)):
                    msg = Image()
                    msg.header.stamp = rospy.Time(first_stamp + 0.1 * k)
                    msg.header.frame_id = 'camera_left'
                    msg.width, msg.height, msg.encoding, msg.step = 640, 192, 'mono8', 640
                    msg.data = texture[2:194, column:column + 640].astype(np.uint8).tobytes()
                    publisher.publish(msg)
                time.sleep(0.3)

        wait_until(lambda: left.get_num_connections() > 0 and right.get_num_connections() > 0,
                   10.0)
        play(300.0, 6100.0)
        wait_until(lambda: len(features) >= 4, 10.0)
        first = list(features)
        play(310.0, 6200.0)
        wait_until(lambda: any(m.header.stamp.to_sec() > 6150.0 for m in features[len(first):]),
                   10.0)
        time.sleep(1.0)
        second = [m for m in features if m.header.stamp.to_sec() > 6150.0]
        ids_first = {f.id for m in first for f in m.features}
        ids_second = {f.id for m in second for f in m.features}
        log('new calibration: %d + %d feature messages, ids %s-%s then %s-%s' % (
            len(first), len(second), min(ids_first, default=None), max(ids_first, default=None),
            min(ids_second, default=None), max(ids_second, default=None)))
        self.assertGreaterEqual(len(first), 4)
        self.assertGreaterEqual(len(second), 4)
        self.assertGreater(len(ids_first), 50)
        self.assertGreater(len(ids_second), 50)
        self.assertGreater(min(ids_second), max(ids_first))

    def test_05_bag_played_again_restarts_both(self):
        """Time goes back to the start of the drive (and from test_03's stamps): tracker and
        estimator each restart once and track the drive anew, new ids included. The twist comes
        REPLAY_TWIST_DELAY_S late in wall time: every pair but the first still waits for it."""
        with self.lock:
            features_before, odometry_before = len(self.features), len(self.odometry)
            ids_before = {f.id for msg in self.features for f in msg.features}
        predictions_before = int(self.latest_status('stereo_tracker')[1]['twist_predictions'])
        relay = DelayedRelay('/imu/twist_recorded', '/imu/twist', REPLAY_TWIST_DELAY_S)
        try:
            required = dict(self.required)
            del required['/imu/twist']
            required['/imu/twist_recorded'] = (rospy.get_name(),)
            relay.wait_for_subscriber()
            play_bag(self.bag, '/stereo_tracker_replay_player', PLAY_RATE, required,
                     ['/imu/twist:=/imu/twist_recorded'])
            self.wait_for_last_image(odometry_from=odometry_before, features_from=features_before)
        finally:
            relay.close()
        with self.lock:
            replay_features = self.features[features_before:]
            replay_odometry = self.odometry[odometry_before:]
        tracker = self.latest_status('stereo_tracker')[1]
        estimator = self.latest_status('estimator')[1]
        log('replay: %d feature messages, %d odometry, resets tracker %s, estimator %s' %
            (len(replay_features), len(replay_odometry), tracker.get('time_jump_resets'),
             estimator.get('time_jump_resets')))
        def predictions_now():  # the diagnostics come once a second
            return int(self.latest_status('stereo_tracker')[1]['twist_predictions'])
        wait_until(lambda: predictions_now() >= predictions_before + FRAMES - 1, 5.0)
        predictions = predictions_now() - predictions_before
        log('replay, twist %.1f s late: %d of %d pairs predicted from it' %
            (REPLAY_TWIST_DELAY_S, predictions, FRAMES))
        self.assertEqual(predictions, FRAMES - 1)
        self.assertGreaterEqual(int(tracker.get('time_jump_resets', 0)), 1, tracker)
        self.assertGreaterEqual(int(estimator.get('time_jump_resets', 0)), 1, estimator)
        self.assertEqual(len(replay_features), FRAMES)
        self.assertTrue(all(len(m.features) >= MIN_FEATURES for m in replay_features))
        self.assertFalse({f.id for f in replay_features[0].features} & ids_before)
        gt = {m.header.stamp.to_nsec(): m.pose.pose.position for m in self.groundtruth}
        last = replay_odometry[-1]
        truth, p = gt[last.header.stamp.to_nsec()], last.pose.pose.position
        error = np.linalg.norm([p.x - truth.x, p.y - truth.y, p.z - truth.z])
        log('replay: final position error %.3f m' % error)
        self.assertLess(error, FINAL_ERROR_TOLERANCE_M)


if __name__ == '__main__':
    rostest.rosrun(PKG, 'stereo_tracker_pipeline', StereoTrackerPipelineTest)
