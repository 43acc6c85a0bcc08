"""track_stereo_bag on a small rendered drive written as a bag (play_stereo_images.py --bag): its
features bag carries every message but the images, one feature message per pair, and
vislam_offline takes it; a bag with bad pairs (an encoding the tracker does not take, sizes that
differ, a right image 50 ms late) has them refused and counted, a black pair counted as without a
feature, the other pairs tracked as in the clean bag up to the first fault; a bag played twice
restarts the tracks (ids going on) and tracks its second pass as its first; a bag without
camera_info fails with a message saying so; png-compressed images give the same features, as do
a 12-bit camera's mono16 images, and
play_stereo_images.py's jpeg bag is tracked; its raw-camera bag is rectified (--rectify) into
about the same features, in the rectified frame, and a trajectory that ends at the ground truth,
with each lens model and cropped by a driver's ROI, and a camera_info that cannot rectify is
refused;
scripts/bag_end_to_end.sh evaluates the bag against its ground truth. The live tracker's features
are the same bit for bit: the rostest stereo_tracker.test."""
import os
import re
import subprocess
import unittest

import cv2
import numpy as np
import rosbag
import rospy
from sensor_msgs.msg import CompressedImage

import ekf_test_paths as paths
from ekf_vislam_tools.bag_reading import read_feature_rows
from test_track_stereo_images import tool

FRAMES = 20
LEFT, RIGHT = '/stereo/left/image_rect', '/stereo/right/image_rect'
FEATURES = '/stereo/features'
BAD_ENCODING_PAIR, SMALL_RIGHT_PAIR, LATE_RIGHT_PAIR, BLACK_PAIR = 6, 9, 12, 15


def track(bag, out, *extra):
    """Runs track_stereo_bag; its return code, stdout and stderr."""
    result = subprocess.run([tool('track_stereo_bag'), '--bag', bag, '--out', out] + list(extra),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            universal_newlines=True)
    return result.returncode, result.stdout, result.stderr


def counts(report):
    """The numbers of track_stereo_bag's summary line."""
    m = re.search(r'(\d+) left and (\d+) right images, (\d+) without a partner, (\d+) pairs '
                  r'further apart than ros/max_stamp_difference, (\d+) not decodable; (\d+) pairs '
                  r'tracked \((\d+) predicted from the twist, (\d+) without a feature\), (\d+) '
                  r'refused, (\d+) dropped without camera_info, (\d+) restarts', report)
    keys = ('left', 'right', 'unpaired', 'unsynchronized', 'undecodable', 'tracked', 'predicted',
            'featureless', 'refused', 'no_camera_info', 'restarts')
    return dict(zip(keys, map(int, m.groups())))


def write_faulty_bag(clean, faulty):
    """The clean bag with three bad pairs, counted by pair index on the left topic."""
    seen = {LEFT: -1, RIGHT: -1}
    with rosbag.Bag(clean) as src, rosbag.Bag(faulty, 'w') as dst:
        for topic, msg, t in src.read_messages():
            if topic in seen:
                seen[topic] += 1
                k = seen[topic]
                if k == BAD_ENCODING_PAIR and topic == LEFT:
                    msg.encoding = '32FC1'
                    msg.step *= 4
                    msg.data = bytes(len(msg.data) * 4)
                elif k == SMALL_RIGHT_PAIR and topic == RIGHT:
                    msg.height -= 2
                    msg.data = msg.data[:msg.step * msg.height]
                elif k == LATE_RIGHT_PAIR and topic == RIGHT:
                    msg.header.stamp += rospy.Duration(0.05)
                elif k == BLACK_PAIR:
                    msg.data = bytes(len(msg.data))
            dst.write(topic, msg, t)


class TrackStereoBagTest(unittest.TestCase):

    @classmethod
    def setUpClass(cls):
        cls.tmp = paths.make_temp_dir(prefix='ekf_vislam_track_bag_test_')
        folder = os.path.join(cls.tmp, 'drive')
        result = paths.run_script('render_stereo_drive.py', folder, '--frames', str(FRAMES))
        assert result.returncode == 0, result.stderr
        cls.bag = os.path.join(cls.tmp, 'drive.bag')
        result = paths.run_script('play_stereo_images.py', folder, '--bag', cls.bag)
        assert result.returncode == 0, result.stderr
        cls.tracked = os.path.join(cls.tmp, 'tracked.bag')
        cls.rc, cls.report, cls.errors = track(cls.bag, cls.tracked)
        # The same drive as a raw rig's (play_stereo_images.py --raw-camera, plumb_bob lenses).
        cls.raw_bag = os.path.join(cls.tmp, 'raw.bag')
        result = paths.run_script('play_stereo_images.py', folder, '--bag', cls.raw_bag,
                                  '--raw-camera')
        assert result.returncode == 0, result.stderr

    @classmethod
    def tearDownClass(cls):
        paths.remove_dir(cls.tmp)

    def end_error(self, features_bag, images_bag, name):
        """vislam_offline over `features_bag`: its last position's distance (m) from the last
        ground truth of `images_bag`, unaligned."""
        result = paths.run_vislam_offline(features_bag, os.path.join(self.tmp, name))
        self.assertEqual(result.returncode, 0, result.stderr)
        last = np.loadtxt(os.path.join(self.tmp, name, 'trajectory.tum'))[-1]
        with rosbag.Bag(images_bag) as bag:
            truth = [m.pose.pose.position
                     for _, m, _ in bag.read_messages(['/groundtruth/odometry'])][-1]
        return np.linalg.norm(last[1:4] - [truth.x, truth.y, truth.z])

    def test_every_pair_is_tracked_into_a_bag_vislam_offline_takes(self):
        self.assertEqual(self.rc, 0, self.errors)
        c = counts(self.report)
        self.assertEqual((c['left'], c['right'], c['tracked'], c['refused']),
                         (FRAMES, FRAMES, FRAMES, 0), self.report)
        self.assertEqual(c['predicted'], FRAMES - 1)  # all but the first, from the twist
        self.assertEqual(c['featureless'], 0)
        with rosbag.Bag(self.bag) as src, rosbag.Bag(self.tracked) as out:
            topics = src.get_type_and_topic_info()[1]
            for topic in topics:
                expected = 0 if topic in (LEFT, RIGHT) else src.get_message_count(topic)
                self.assertEqual(out.get_message_count(topic), expected, topic)
        tracked = read_feature_rows(self.tracked)
        self.assertEqual(len(tracked), FRAMES)
        rows = np.array([row for _, _, rows in tracked for row in rows])
        self.assertTrue(np.all(np.isfinite(rows)))
        self.assertGreater(rows.shape[0], 100 * FRAMES)
        self.assertTrue(np.all(rows[:, 1] - rows[:, 3] > 0))  # positive disparity
        out = os.path.join(self.tmp, 'slam')
        result = paths.run_vislam_offline(self.tracked, out)
        self.assertEqual(result.returncode, 0, result.stderr)
        self.assertEqual(np.loadtxt(os.path.join(out, 'trajectory.tum')).shape[0], FRAMES)

    def test_bad_pairs_are_refused_and_counted(self):
        faulty = os.path.join(self.tmp, 'faulty.bag')
        write_faulty_bag(self.bag, faulty)
        out = os.path.join(self.tmp, 'faulty_tracked.bag')
        rc, report, errors = track(faulty, out)
        self.assertEqual(rc, 0, errors)
        c = counts(report)
        # As the node: the synchronizer pairs the late right image with its left (nothing pairs
        # better), and the pair is skipped as unsynchronized.
        self.assertEqual((c['tracked'], c['refused'], c['unsynchronized'], c['unpaired']),
                         (FRAMES - 3, 2, 1, 0), report)
        self.assertIn('more than ros/max_stamp_difference', errors)
        self.assertEqual(c['featureless'], 1, report)  # the black pair: tracked, no feature
        self.assertIn('encoding', errors)
        self.assertIn('size', errors)
        self.assertIn('gave no feature', errors)
        clean, bad = read_feature_rows(self.tracked), read_feature_rows(out)
        self.assertEqual(bad[:BAD_ENCODING_PAIR], clean[:BAD_ENCODING_PAIR])
        rows = np.array([row for _, _, rows in bad for row in rows])
        self.assertTrue(np.all(np.isfinite(rows)))

    def test_a_bag_played_twice_restarts_the_tracks_and_the_ids_go_on(self):
        twice = os.path.join(self.tmp, 'twice.bag')
        with rosbag.Bag(self.bag) as src, rosbag.Bag(twice, 'w') as dst:
            messages = list(src.read_messages())
            shift = messages[-1][2] - messages[0][2] + rospy.Duration(1.0)
            for topic, msg, t in messages:
                dst.write(topic, msg, t)
            for topic, msg, t in messages:
                if topic != '/tf_static':
                    dst.write(topic, msg, t + shift)
        out = os.path.join(self.tmp, 'twice_tracked.bag')
        rc, report, errors = track(twice, out)
        self.assertEqual(rc, 0, errors)
        c = counts(report)
        self.assertEqual((c['tracked'], c['restarts']), (2 * FRAMES, 1), report)
        self.assertIn('went back', errors)
        tracked = read_feature_rows(out)
        first, second = tracked[:FRAMES], tracked[FRAMES:]
        self.assertEqual(first, read_feature_rows(self.tracked))
        last_id = max(row[0] for _, _, rows in first for row in rows)
        for (stamp_a, frame_a, rows_a), (stamp_b, frame_b, rows_b) in zip(first, second):
            self.assertEqual((stamp_a, frame_a), (stamp_b, frame_b))
            self.assertEqual([r[1:] for r in rows_a], [r[1:] for r in rows_b])
            self.assertGreater(min(r[0] for r in rows_b), last_id)

    def test_png_compressed_images_give_the_same_features(self):
        # Lossless compression: the features of the raw images, bit for bit; one image that does
        # not decode is said and counted, its pair lost.
        compressed = os.path.join(self.tmp, 'compressed.bag')
        with rosbag.Bag(self.bag) as src, rosbag.Bag(compressed, 'w') as dst:
            k = 0
            for topic, msg, t in src.read_messages():
                if topic in (LEFT, RIGHT):
                    image = np.frombuffer(msg.data, np.uint8).reshape(msg.height, msg.width)
                    out = CompressedImage(header=msg.header, format='png')
                    out.data = cv2.imencode('.png', image)[1].tobytes()
                    if topic == LEFT:
                        k += 1
                        if k == FRAMES:
                            out.data = b'not an image'
                    dst.write(topic + '/compressed', out, t)
                else:
                    dst.write(topic, msg, t)
        out = os.path.join(self.tmp, 'compressed_tracked.bag')
        rc, report, errors = track(compressed, out, '--left-topic', LEFT + '/compressed',
                                   '--right-topic', RIGHT + '/compressed')
        self.assertEqual(rc, 0, errors)
        c = counts(report)
        self.assertEqual((c['undecodable'], c['unpaired'], c['tracked']), (1, 0, FRAMES - 1),
                         report)
        self.assertIn('cannot be decoded', errors)
        self.assertEqual(read_feature_rows(out), read_feature_rows(self.tracked)[:FRAMES - 1])

    def test_a_12_bit_cameras_mono16_images_give_the_same_features(self):
        # A 12-bit camera's values, stored from bit 0 up as mono16: each 8-bit level times 16
        # plus seeded low bits that round away (0-7). The tracker reads 12 significant bits from
        # the images (ros/image_bits 0) and tracks the 8-bit images' features bit for bit.
        deep = os.path.join(self.tmp, 'mono16.bag')
        rng = np.random.default_rng(4)
        with rosbag.Bag(self.bag) as src, rosbag.Bag(deep, 'w') as dst:
            for topic, msg, t in src.read_messages():
                if topic in (LEFT, RIGHT):
                    image = np.frombuffer(msg.data, np.uint8).reshape(msg.height, msg.width)
                    low = rng.integers(0, 8, image.shape)
                    values = (image.astype(np.uint16) * 16 + low).astype('<u2')
                    msg.encoding, msg.is_bigendian, msg.step = 'mono16', 0, 2 * msg.width
                    msg.data = values.tobytes()
                dst.write(topic, msg, t)
        out = os.path.join(self.tmp, 'mono16_tracked.bag')
        rc, report, errors = track(deep, out)
        self.assertEqual(rc, 0, errors)
        self.assertEqual(counts(report)['tracked'], FRAMES, report)
        self.assertIn('16-bit images: value / 16 tracked (12 significant bits, read from the '
                      'images)', errors)
        self.assertEqual(read_feature_rows(out), read_feature_rows(self.tracked))

    def test_jpeg_bag_of_play_stereo_images_is_tracked(self):
        # play_stereo_images.py --compressed jpeg writes CompressedImage on the /compressed
        # topics: every pair decodes and is tracked, with about the raw images' features.
        jpeg = os.path.join(self.tmp, 'jpeg.bag')
        result = paths.run_script('play_stereo_images.py', os.path.join(self.tmp, 'drive'),
                                  '--bag', jpeg, '--compressed', 'jpeg', '--jpeg-quality', '90')
        self.assertEqual(result.returncode, 0, result.stderr)
        with rosbag.Bag(jpeg) as bag:
            topics = bag.get_type_and_topic_info().topics
            self.assertEqual(topics[LEFT + '/compressed'].msg_type, 'sensor_msgs/CompressedImage')
            self.assertNotIn(LEFT, topics)
            raw_bytes = sum(len(m.data) for _, m, _ in rosbag.Bag(self.bag).read_messages([LEFT]))
            jpeg_bytes = sum(len(m.data) for _, m, _ in bag.read_messages([LEFT + '/compressed']))
        self.assertLess(jpeg_bytes, 0.5 * raw_bytes)
        out = os.path.join(self.tmp, 'jpeg_tracked.bag')
        rc, report, errors = track(jpeg, out, '--left-topic', LEFT + '/compressed',
                                   '--right-topic', RIGHT + '/compressed')
        self.assertEqual(rc, 0, errors)
        c = counts(report)
        self.assertEqual((c['undecodable'], c['tracked']), (0, FRAMES), report)
        observations = sum(len(rows) for _, _, rows in read_feature_rows(out))
        raw_observations = sum(len(rows) for _, _, rows in read_feature_rows(self.tracked))
        self.assertGreater(observations, 0.8 * raw_observations)

    def test_bag_end_to_end_evaluates_against_the_bags_ground_truth(self):
        # scripts/bag_end_to_end.sh: the tool, vislam_offline in both modes, evaluate.py against
        # /groundtruth/odometry. Measured: SLAM 0.0175 m, dead reckoning 0.0137 m over 15.3 m.
        result = subprocess.run(['bash', os.path.join(paths.SCRIPTS_DIR, 'bag_end_to_end.sh'),
                                 self.bag, '--out', os.path.join(self.tmp, 'e2e')],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                universal_newlines=True, env=paths.script_env())
        self.assertEqual(result.returncode, 0, result.stderr)
        ate = {m: float(a) for m, a in re.findall(r'^(\w+) +ATE ([0-9.]+) m', result.stdout, re.M)}
        self.assertEqual(set(ate), {'slam', 'deadreckoning'}, result.stdout)
        self.assertLess(ate['slam'], 0.05)
        self.assertLess(ate['deadreckoning'], 0.05)

    def test_raw_camera_images_are_rectified_with_their_camera_info(self):
        # play_stereo_images.py --raw-camera: the raw images of distorted, turned cameras with
        # their camera_info. --rectify tracks them about as the rectified images, in the
        # rectified frame, whose tf it writes; the estimator's trajectory ends at the ground truth.
        raw = self.raw_bag
        out = os.path.join(self.tmp, 'raw_tracked.bag')
        rc, report, errors = track(raw, out, '--rectify')
        self.assertEqual(rc, 0, errors)
        c = counts(report)
        self.assertEqual((c['tracked'], c['refused']), (FRAMES, 0), report)
        self.assertGreater(float(re.search(r'rectification \(ros/rectify\) per pair: median '
                                           r'([0-9.]+) ms', report).group(1)), 0.0, report)
        self.assertNotIn('rectification', self.report)  # rectified images: none
        tracked, clean = read_feature_rows(out), read_feature_rows(self.tracked)
        self.assertEqual({frame for _, frame, _ in tracked}, {'camera_left_rect'})
        observations = sum(len(rows) for _, _, rows in tracked)
        clean_observations = sum(len(rows) for _, _, rows in clean)
        self.assertGreater(observations, 0.85 * clean_observations)
        with rosbag.Bag(out) as bag:
            rectified = [t for _, m, _ in bag.read_messages(['/tf_static']) for t in m.transforms
                         if t.child_frame_id == 'camera_left_rect']
        self.assertEqual([t.header.frame_id for t in rectified], ['camera_left'])
        # vislam_offline: the last pose against the ground truth, unaligned: 0.0333 m measured;
        # 0.0698 m with the features given in the raw camera's frame instead (its turn ignored).
        self.assertLess(self.end_error(out, raw, 'raw_slam'), 0.05)
        # The same images tracked without rectification: almost no stereo match survives.
        rc, _, errors = track(raw, os.path.join(self.tmp, 'raw_unrectified.bag'),
                              '--left-topic', '/stereo/left/image_raw', '--right-topic',
                              '/stereo/right/image_raw')
        self.assertEqual(rc, 0, errors)
        unrectified = read_feature_rows(os.path.join(self.tmp, 'raw_unrectified.bag'))
        self.assertLess(sum(len(rows) for _, _, rows in unrectified), 0.2 * clean_observations)

    def test_other_lens_models_are_rectified_end_to_end(self):
        # The raw rig with rational_polynomial and with equidistant (fisheye) lenses: tracked as
        # the rectified images (observations measured: 0.9535 and 0.9575 of theirs), the
        # trajectory ending at the ground truth (0.0326 and 0.0322 m unaligned; plumb_bob 0.0333).
        # The fisheye rig's camera_info relabelled plumb_bob: 0.7023 of the observations, 0.0862 m.
        clean_observations = sum(len(rows) for _, _, rows in read_feature_rows(self.tracked))
        for model in ('rational_polynomial', 'equidistant'):
            raw = os.path.join(self.tmp, 'raw_%s.bag' % model)
            result = paths.run_script('play_stereo_images.py', os.path.join(self.tmp, 'drive'),
                                      '--bag', raw, '--raw-camera', '--distortion-model', model)
            self.assertEqual(result.returncode, 0, result.stderr)
            with rosbag.Bag(raw) as bag:
                models = {m.distortion_model for _, m, _ in
                          bag.read_messages(['/stereo/left/camera_info'])}
            self.assertEqual(models, {model})
            out = os.path.join(self.tmp, 'raw_tracked_%s.bag' % model)
            rc, report, errors = track(raw, out, '--rectify')
            self.assertEqual(rc, 0, errors)
            self.assertEqual((counts(report)['tracked'], counts(report)['refused']),
                             (FRAMES, 0), report)
            observations = sum(len(rows) for _, _, rows in read_feature_rows(out))
            self.assertGreater(observations, 0.85 * clean_observations, model)
            self.assertLess(self.end_error(out, raw, 'slam_' + model), 0.05, model)

    def test_a_drivers_region_of_interest_is_taken_from_camera_info(self):
        # The raw rig's images cropped as a driver's ROI gives them, the camera_info unchanged
        # but for its roi (K, P and the size stay the sensor's): --rectify tracks the crops in
        # their own pixels and the estimator takes the same projection, so the trajectory still
        # ends at the ground truth. The crops without the roi in camera_info are refused.
        raw = self.raw_bag
        x, y, width, height = 48, 16, 560, 168
        for with_roi in (True, False):
            cropped = os.path.join(self.tmp, 'raw_roi_%s.bag' % with_roi)
            with rosbag.Bag(raw) as src, rosbag.Bag(cropped, 'w') as dst:
                for topic, msg, t in src.read_messages():
                    if topic.endswith('/image_raw'):
                        image = np.frombuffer(msg.data, np.uint8).reshape(msg.height, msg.width)
                        msg.data = image[y:y + height, x:x + width].tobytes()
                        msg.width, msg.height, msg.step = width, height, width
                    elif topic.endswith('/camera_info') and with_roi:
                        msg.roi.x_offset, msg.roi.y_offset = x, y
                        msg.roi.width, msg.roi.height = width, height
                    dst.write(topic, msg, t)
            out = os.path.join(self.tmp, 'raw_roi_tracked_%s.bag' % with_roi)
            rc, report, errors = track(cropped, out, '--rectify')
            if not with_roi:
                self.assertEqual(rc, 1, errors)
                self.assertEqual(counts(report)['refused'], FRAMES, report)
                self.assertIn('differs from its camera_info', errors)
                continue
            self.assertEqual(rc, 0, errors)
            self.assertEqual((counts(report)['tracked'], counts(report)['refused']),
                             (FRAMES, 0), report)
            rows = np.array([row for _, _, rows in read_feature_rows(out) for row in rows])
            self.assertLess(rows[:, 1].max(), width)  # the crop's pixels (u left)
            self.assertGreater(rows.shape[0], 100 * FRAMES)
            # The last pose against the ground truth, unaligned: 0.0338 m measured (0.0333 m
            # uncropped); 0.6735 m with the estimator's projection ignoring the roi.
            self.assertLess(self.end_error(out, raw, 'roi_slam'), 0.05)

    def test_a_camera_info_that_cannot_rectify_is_refused(self):
        raw = os.path.join(self.tmp, 'raw_fov.bag')
        result = paths.run_script('play_stereo_images.py', os.path.join(self.tmp, 'drive'),
                                  '--bag', raw, '--raw-camera', '--max-frames', '5')
        self.assertEqual(result.returncode, 0, result.stderr)
        with rosbag.Bag(raw) as src, rosbag.Bag(raw + '.fov', 'w') as dst:
            for topic, msg, t in src.read_messages():
                if topic == '/stereo/left/camera_info':
                    msg.distortion_model = 'fov'
                dst.write(topic, msg, t)
        rc, report, errors = track(raw + '.fov', os.path.join(self.tmp, 'fov.bag'), '--rectify')
        self.assertEqual(rc, 1, errors)
        self.assertEqual(counts(report)['refused'], 5, report)
        self.assertIn("distortion model 'fov'", errors)

    def test_a_bag_without_camera_info_says_so(self):
        rc, report, errors = track(self.bag, os.path.join(self.tmp, 'none.bag'),
                                   '--left-info-topic', '/absent')
        self.assertEqual(rc, 1)
        self.assertEqual(counts(report)['no_camera_info'], FRAMES)
        self.assertIn('no camera_info', errors)

    def test_a_topic_that_is_not_an_image_is_refused_with_the_bags_image_topics(self):
        rc, _, errors = track(self.bag, os.path.join(self.tmp, 'none.bag'), '--left-topic',
                              '/stereo/left/image_raw')
        self.assertEqual(rc, 2)
        self.assertIn(LEFT, errors)


if __name__ == '__main__':
    unittest.main()
