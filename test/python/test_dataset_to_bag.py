"""Tests of scripts/dataset_to_bag.py (run as a subprocess) and ekf_vislam_tools.dataset."""
import collections
import glob
import os
import json
import shutil
import signal
import socket
import subprocess
import time
import unittest

import numpy as np
import rosbag

import ekf_test_paths
from ekf_vislam_tools import bag_writer, se3, simulator
from ekf_vislam_tools.dataset import DatasetError, load_dataset

SCRIPT = 'dataset_to_bag.py'
SENSOR_TOPICS = (bag_writer.TOPIC_TWIST, bag_writer.TOPIC_LEFT_INFO, bag_writer.TOPIC_RIGHT_INFO,
                 bag_writer.TOPIC_FEATURES)

# A 2019-style extrinsic as stored in the course files: rotation of cam_T_imu, translation of
# imu_T_cam (camera 1.14 m ahead, 0.31 m right, 0.73 m above the IMU).
STORED_ROTATION = se3.so3_exp([0.01, -0.02, 0.005]) @ simulator.KITTI_CAM_T_IMU[:3, :3]
STORED_TRANSLATION = np.array([1.1439, -0.3127, 0.7265])


def synthetic_2019(num_frames=6):
    """A tiny 2019-layout dataset with known content (ids 0-3; frame 5 has no feature)."""
    t = 1.3e9 + 0.1 * np.arange(num_frames) + 0.001 * np.sin(np.arange(num_frames))
    features = -np.ones((4, 4, num_frames))
    features[:, 0, 0:3] = [[600.0], [180.0], [590.0], [180.0]]
    features[:, 1, 1:5] = [[100.0], [50.0], [80.0], [50.5]]
    features[:, 1, 2] = [300.0, 60.0, 320.0, 60.0]      # negative disparity: written as is
    features[:, 2, 3] = [400.0, 200.0, 390.0, -1.0]     # one -1 coordinate: still observed
    features[:, 3, 0:5] = [[1000.0], [300.0], [995.0], [300.0]]
    cam_T_imu = np.eye(4)
    cam_T_imu[:3, :3] = STORED_ROTATION
    cam_T_imu[:3, 3] = STORED_TRANSLATION
    frames = np.arange(num_frames, dtype=float)
    return {
        'time_stamps': t[None, :],
        'features': features,
        'linear_velocity': np.stack([5.0 + frames, 0.1 * frames, -0.05 * frames]),
        'rotational_velocity': np.stack([0.01 * frames, -0.02 * frames, 0.1 + 0.01 * frames]),
        'K': simulator.KITTI_K.copy(),
        'b': np.array(0.54),
        'cam_T_imu': cam_T_imu,
    }


def synthetic_later():
    """The same content in the later layout: 't' (T,), angular_velocity, imu_T_cam."""
    arrays = synthetic_2019()
    correct = arrays['cam_T_imu'].copy()
    correct[:3, 3] = -correct[:3, :3] @ correct[:3, 3]
    return {
        't': arrays['time_stamps'][0],
        'features': arrays['features'],
        'linear_velocity': arrays['linear_velocity'],
        'angular_velocity': arrays['rotational_velocity'],
        'K': arrays['K'],
        'b': arrays['b'],
        'imu_T_cam': se3.inverse(correct),
    }


def read_bag(path):
    """-> (messages: topic -> [(msg, bag time)], order: [topic], connection headers by topic)."""
    messages = collections.defaultdict(list)
    order = []
    with rosbag.Bag(path) as bag:
        headers = {c.topic: c.header for c in bag._get_connections()}
        for topic, msg, stamp in bag.read_messages():
            messages[topic].append((msg, stamp))
            order.append(topic)
    return messages, order, headers


def transform_matrix(transform):
    T = np.eye(4)
    r, p = transform.rotation, transform.translation
    T[:3, :3] = se3.quaternion_to_rotation([r.x, r.y, r.z, r.w])
    T[:3, 3] = [p.x, p.y, p.z]
    return T


def pose_matrix(pose):
    T = np.eye(4)
    q, p = pose.orientation, pose.position
    T[:3, :3] = se3.quaternion_to_rotation([q.x, q.y, q.z, q.w])
    T[:3, 3] = [p.x, p.y, p.z]
    return T


def tf_by_child(messages):
    (tf_msg, _), = messages[bag_writer.TOPIC_TF_STATIC]
    return {tf.child_frame_id: tf for tf in tf_msg.transforms}


class ConverterTestCase(unittest.TestCase):
    """Helpers: write npz files, run the converter, check the outcome."""

    def setUp(self):
        self.tmp = ekf_test_paths.make_temp_dir(self)

    def write_npz(self, name, arrays):
        return ekf_test_paths.write_npz(self.tmp, name, arrays)

    def convert(self, npz, *options, bag_name='out.bag'):
        bag = os.path.join(self.tmp, bag_name)
        return ekf_test_paths.run_script(SCRIPT, npz, bag, *options), bag

    def assert_converted(self, proc, bag):
        self.assertEqual(proc.returncode, 0, proc.stderr)
        self.assertTrue(os.path.isfile(bag))
        self.assertEqual(glob.glob(bag + '.tmp-*'), [])
        self.assertIn('wrote', proc.stdout)

    def assert_clean_failure(self, proc, bag, *needles):
        """Exit code 2, one line on stderr naming the problem, no traceback, no bag left."""
        self.assertEqual(proc.returncode, 2, proc.stdout + proc.stderr)
        lines = proc.stderr.strip().splitlines()
        self.assertEqual(len(lines), 1, proc.stderr)
        self.assertTrue(lines[0].startswith('dataset_to_bag.py: error: '), lines[0])
        for needle in needles:
            self.assertIn(needle, lines[0])
        self.assertNotIn('Traceback', proc.stderr)
        self.assertFalse(os.path.exists(bag))
        self.assertEqual(glob.glob(bag + '.tmp-*'), [])


class RoundTripTest(unittest.TestCase):
    """A simulated dataset with ground truth -> bag -> read back and compare."""

    FRAMES = 40

    @classmethod
    def setUpClass(cls):
        cls.tmp = ekf_test_paths.make_temp_dir()
        cls.addClassCleanup(ekf_test_paths.remove_dir, cls.tmp)
        cls.sim = simulator.simulate(21, frames=cls.FRAMES)
        paths = simulator.write_outputs(cls.sim, os.path.join(cls.tmp, 'sim'))
        cls.bag = os.path.join(cls.tmp, 'sim.bag')
        cls.proc = ekf_test_paths.run_script(SCRIPT, paths['npz'], cls.bag, '--groundtruth',
                                             paths['groundtruth'])
        if cls.proc.returncode == 0:
            cls.messages, cls.order, cls.headers = read_bag(cls.bag)

    def setUp(self):
        self.assertEqual(self.proc.returncode, 0, self.proc.stderr)

    def test_output(self):
        self.assertEqual(self.proc.stderr, '')   # simulator files: no extrinsic notice
        observations = int(np.sum(~np.all(self.sim['features'] == -1, axis=0)))
        self.assertIn('%d frames' % self.FRAMES, self.proc.stdout)
        self.assertIn('%d observations' % observations, self.proc.stdout)
        self.assertIn(self.bag, self.proc.stdout)
        self.assertEqual(glob.glob(self.bag + '.tmp-*'), [])

    def test_counts(self):
        counts = {topic: len(msgs) for topic, msgs in self.messages.items()}
        expected = {topic: self.FRAMES for topic in SENSOR_TOPICS}
        expected[bag_writer.TOPIC_TF_STATIC] = 1
        expected[bag_writer.TOPIC_GROUNDTRUTH] = self.FRAMES
        self.assertEqual(counts, expected)

    def test_order_and_stamps(self):
        self.assertEqual(self.order[0], bag_writer.TOPIC_TF_STATIC)
        sensor_order = [t for t in self.order if t in SENSOR_TOPICS]
        self.assertEqual(sensor_order, list(SENSOR_TOPICS) * self.FRAMES)
        for topic in SENSOR_TOPICS + (bag_writer.TOPIC_GROUNDTRUTH,):
            for k, (msg, stamp) in enumerate(self.messages[topic]):
                self.assertEqual(msg.header.stamp, stamp)
                self.assertAlmostEqual(stamp.to_sec(), self.sim['t'][k], delta=1e-6)
        (tf_msg, stamp), = self.messages[bag_writer.TOPIC_TF_STATIC]
        self.assertAlmostEqual(stamp.to_sec(), self.sim['t'][0], delta=1e-6)

    def test_twist(self):
        for k, (msg, _) in enumerate(self.messages[bag_writer.TOPIC_TWIST]):
            self.assertEqual(msg.header.frame_id, 'imu')
            linear, angular = msg.twist.linear, msg.twist.angular
            np.testing.assert_array_equal([linear.x, linear.y, linear.z],
                                          self.sim['linear_velocity'][:, k])
            np.testing.assert_array_equal([angular.x, angular.y, angular.z],
                                          self.sim['rotational_velocity'][:, k])

    def test_features(self):
        features = self.sim['features']
        observed = ~np.all(features == -1, axis=0)
        for k, (msg, _) in enumerate(self.messages[bag_writer.TOPIC_FEATURES]):
            self.assertEqual(msg.header.frame_id, 'camera_left')
            ids = [f.id for f in msg.features]
            np.testing.assert_array_equal(ids, np.flatnonzero(observed[:, k]))
            values = np.array([[f.u_left, f.v_left, f.u_right, f.v_right]
                               for f in msg.features]).T
            np.testing.assert_allclose(values, features[:, ids, k], rtol=1e-6)

    def test_camera_info(self):
        K, b = self.sim['K'], self.sim['b']
        fx = K[0, 0]
        lefts = self.messages[bag_writer.TOPIC_LEFT_INFO]
        rights = self.messages[bag_writer.TOPIC_RIGHT_INFO]
        for (left, _), (right, _) in zip(lefts, rights):
            self.assertEqual(left.header.frame_id, 'camera_left')
            self.assertEqual(right.header.frame_id, 'camera_right')
            for info in (left, right):
                self.assertEqual((info.width, info.height), (1241, 376))
                np.testing.assert_allclose(info.K, K.reshape(-1))
                np.testing.assert_allclose(info.R, np.eye(3).reshape(-1))
                np.testing.assert_array_equal(info.D, np.zeros(5))
                self.assertEqual(info.distortion_model, 'plumb_bob')
            P = np.array([[fx, 0, K[0, 2], 0], [0, K[1, 1], K[1, 2], 0], [0, 0, 1, 0]])
            np.testing.assert_allclose(np.reshape(left.P, (3, 4)), P)
            P[0, 3] = -fx * b
            np.testing.assert_allclose(np.reshape(right.P, (3, 4)), P)

    def test_tf_static(self):
        header = self.headers[bag_writer.TOPIC_TF_STATIC]
        self.assertEqual(header.get('latching'), b'1')
        self.assertEqual(header.get('callerid'), b'/dataset_to_bag')
        transforms = tf_by_child(self.messages)
        self.assertEqual(set(transforms), {'camera_left', 'camera_right'})
        imu_cam = transforms['camera_left']
        self.assertEqual(imu_cam.header.frame_id, 'imu')
        np.testing.assert_allclose(transform_matrix(imu_cam.transform),
                                   se3.inverse(self.sim['cam_T_imu']), atol=1e-9)
        left_right = transforms['camera_right']
        self.assertEqual(left_right.header.frame_id, 'camera_left')
        expected = np.eye(4)
        expected[0, 3] = self.sim['b']
        np.testing.assert_allclose(transform_matrix(left_right.transform), expected, atol=1e-12)

    def test_groundtruth(self):
        for k, (msg, _) in enumerate(self.messages[bag_writer.TOPIC_GROUNDTRUTH]):
            self.assertEqual(msg.header.frame_id, 'world')
            self.assertEqual(msg.child_frame_id, 'imu')
            np.testing.assert_allclose(pose_matrix(msg.pose.pose), self.sim['world_T_imu'][k],
                                       atol=1e-6)


class FeatureOrderTest(unittest.TestCase):
    def test_oldest_track_first_also_in_a_column_given_again(self):
        # Columns 0-2 over 6 frames; column 0 holds a track in frames 0-1 and another from 4 on.
        observed = np.zeros((3, 6), dtype=bool)
        observed[0, [0, 1, 4, 5]] = True
        observed[1, 0:6] = True
        observed[2, 2:6] = True
        order = [list(ids) for ids in bag_writer.features_by_age(observed)]
        self.assertEqual(order, [[0, 1], [0, 1], [1, 2], [1, 2], [1, 2, 0], [1, 2, 0]])

    def test_course_file_columns_keep_their_order(self):
        # Ids that grow with time (the course files, the tracker's): the column order.
        observed = np.zeros((4, 5), dtype=bool)
        for j, (first, last) in enumerate(((0, 2), (0, 4), (1, 3), (3, 4))):
            observed[j, first:last + 1] = True
        for k, ids in enumerate(bag_writer.features_by_age(observed)):
            np.testing.assert_array_equal(ids, np.flatnonzero(observed[:, k]))


class TwistTypeTest(unittest.TestCase):
    """--twist-type writes /imu/twist as any of the three types the estimator takes, with the same
    values; --twist-covariance fills the covariance of the two that carry one."""
    FRAMES = 12

    @classmethod
    def setUpClass(cls):
        cls.tmp = ekf_test_paths.make_temp_dir()
        cls.addClassCleanup(ekf_test_paths.remove_dir, cls.tmp)
        cls.sim = simulator.simulate(22, frames=cls.FRAMES)
        cls.npz = simulator.write_outputs(cls.sim, os.path.join(cls.tmp, 'sim'))['npz']

    def twists(self, *args):
        bag = os.path.join(self.tmp, 'x.bag')
        proc = ekf_test_paths.run_script(SCRIPT, self.npz, bag, *args)
        self.assertEqual(proc.returncode, 0, proc.stderr)
        messages, _, headers = read_bag(bag)
        return [m for m, _ in messages[bag_writer.TOPIC_TWIST]], headers[bag_writer.TOPIC_TWIST]

    def test_each_type_carries_the_same_twist(self):
        for twist_type, datatype in (('twist_stamped', 'geometry_msgs/TwistStamped'),
                                     ('twist_with_covariance',
                                      'geometry_msgs/TwistWithCovarianceStamped'),
                                     ('odometry', 'nav_msgs/Odometry')):
            msgs, header = self.twists('--twist-type', twist_type)
            self.assertEqual(header['type'], datatype.encode())
            self.assertEqual(len(msgs), self.FRAMES)
            for k, msg in enumerate(msgs):
                twist = msg.twist if twist_type == 'twist_stamped' else msg.twist.twist
                np.testing.assert_array_equal(
                    [twist.linear.x, twist.linear.y, twist.linear.z],
                    self.sim['linear_velocity'][:, k])
                if twist_type != 'twist_stamped':
                    self.assertEqual(max(abs(c) for c in msg.twist.covariance), 0.0)
                if twist_type == 'odometry':
                    self.assertEqual(msg.child_frame_id, 'imu')

    def test_covariance(self):
        msgs, _ = self.twists('--twist-type', 'odometry', '--twist-covariance', 0.5, 0.05)
        covariance = np.array(msgs[0].twist.covariance).reshape(6, 6)
        np.testing.assert_allclose(np.diag(covariance), [0.25] * 3 + [0.0025] * 3)
        proc = ekf_test_paths.run_script(SCRIPT, self.npz, os.path.join(self.tmp, 'y.bag'),
                                         '--twist-covariance', 0.5, 0.05)
        self.assertNotEqual(proc.returncode, 0)


    def test_imu_odometry_gives_a_gyro_and_a_wheel_odometry_whose_rigid_combination_is_the_twist(
            self):
        bag = os.path.join(self.tmp, 'z.bag')
        proc = ekf_test_paths.run_script(SCRIPT, self.npz, bag, '--twist-type', 'imu_odometry',
                                         '--twist-covariance', 0.5, 0.05)
        self.assertEqual(proc.returncode, 0, proc.stderr)
        messages, _, headers = read_bag(bag)
        self.assertNotIn(bag_writer.TOPIC_TWIST, messages)
        self.assertEqual(headers[bag_writer.TOPIC_IMU]['type'], b'sensor_msgs/Imu')
        base = tf_by_child(messages)['imu']
        self.assertEqual(base.header.frame_id, 'base_link')
        imu_T_base = se3.inverse(transform_matrix(base.transform))
        np.testing.assert_allclose(imu_T_base, bag_writer.IMU_T_BASE, atol=1e-12)
        R, p = imu_T_base[:3, :3], imu_T_base[:3, 3]
        pairs = list(zip(messages[bag_writer.TOPIC_IMU], messages[bag_writer.TOPIC_WHEEL_ODOMETRY]))
        self.assertEqual(len(pairs), self.FRAMES)
        for k, ((imu, _), (odometry, _)) in enumerate(pairs):
            self.assertEqual(imu.header.stamp, odometry.header.stamp)
            self.assertEqual((imu.header.frame_id, odometry.child_frame_id), ('imu', 'base_link'))
            w = np.array([imu.angular_velocity.x, imu.angular_velocity.y, imu.angular_velocity.z])
            v = odometry.twist.twist.linear
            v_imu = R @ np.array([v.x, v.y, v.z]) + np.cross(p, w)
            np.testing.assert_allclose(w, self.sim['rotational_velocity'][:, k], atol=1e-12)
            np.testing.assert_allclose(v_imu, self.sim['linear_velocity'][:, k], atol=1e-9)
            np.testing.assert_allclose(np.diag(np.reshape(imu.angular_velocity_covariance,
                                                          (3, 3))), [0.0025] * 3)
        self.assertEqual(pairs[0][0][0].orientation_covariance[0], -1.0)


class ExtrinsicTest(ConverterTestCase):
    """The 2019 translation fix, its opt-out and the simulator's marker key; the later layout."""

    def imu_T_cam_in_bag(self, bag):
        messages, _, _ = read_bag(bag)
        return transform_matrix(tf_by_child(messages)['camera_left'].transform)

    def test_2019_translation_is_fixed(self):
        proc, bag = self.convert(self.write_npz('old.npz', synthetic_2019()))
        self.assert_converted(proc, bag)
        lines = proc.stderr.strip().splitlines()
        self.assertEqual(len(lines), 1, proc.stderr)
        self.assertIn('cam_T_imu translation corrected', lines[0])
        cam_T_imu = se3.inverse(self.imu_T_cam_in_bag(bag))
        np.testing.assert_allclose(cam_T_imu[:3, :3], STORED_ROTATION, atol=1e-9)
        np.testing.assert_allclose(cam_T_imu[:3, 3], -STORED_ROTATION @ STORED_TRANSLATION,
                                   atol=1e-9)

    def test_2019_translation_kept_on_request(self):
        proc, bag = self.convert(self.write_npz('old.npz', synthetic_2019()),
                                 '--no-fix-extrinsic')
        self.assert_converted(proc, bag)
        self.assertEqual(proc.stderr, '')
        cam_T_imu = se3.inverse(self.imu_T_cam_in_bag(bag))
        np.testing.assert_allclose(cam_T_imu[:3, 3], STORED_TRANSLATION, atol=1e-9)

    def test_marker_key_keeps_translation(self):
        arrays = synthetic_2019()
        arrays['cam_T_imu_translation_correct'] = np.array(True)
        proc, bag = self.convert(self.write_npz('marked.npz', arrays))
        self.assert_converted(proc, bag)
        self.assertEqual(proc.stderr, '')
        cam_T_imu = se3.inverse(self.imu_T_cam_in_bag(bag))
        np.testing.assert_allclose(cam_T_imu[:3, 3], STORED_TRANSLATION, atol=1e-9)

    def test_marker_key_false_is_fixed(self):
        arrays = synthetic_2019()
        arrays['cam_T_imu_translation_correct'] = np.array(False)
        dataset = load_dataset(self.write_npz('unmarked.npz', arrays))
        self.assertTrue(dataset.extrinsic_fixed)

    def test_later_layout(self):
        arrays = synthetic_later()
        proc, bag = self.convert(self.write_npz('later.npz', arrays))
        self.assert_converted(proc, bag)
        self.assertEqual(proc.stderr, '')
        np.testing.assert_allclose(self.imu_T_cam_in_bag(bag), arrays['imu_T_cam'], atol=1e-9)
        messages, _, _ = read_bag(bag)
        twists = messages[bag_writer.TOPIC_TWIST]
        self.assertEqual(len(twists), 6)
        for k, (msg, stamp) in enumerate(twists):
            a = msg.twist.angular
            np.testing.assert_array_equal([a.x, a.y, a.z], arrays['angular_velocity'][:, k])
            self.assertAlmostEqual(stamp.to_sec(), arrays['t'][k], delta=1e-6)
        # Same content as the 2019 file once that one is fixed.
        old = load_dataset(self.write_npz('old.npz', synthetic_2019()))
        new = load_dataset(os.path.join(self.tmp, 'later.npz'))
        self.assertEqual((old.layout, new.layout), ('2019', 'later'))
        np.testing.assert_allclose(new.cam_T_imu, old.cam_T_imu, atol=1e-12)

    def test_time_stamp_shapes(self):
        for shape in ((6,), (1, 6), (6, 1)):
            arrays = synthetic_2019()
            arrays['time_stamps'] = arrays['time_stamps'].reshape(shape)
            dataset = load_dataset(self.write_npz('shape.npz', arrays))
            self.assertEqual(dataset.t.shape, (6,))

    def test_feature_selection(self):
        """Only all-four -1 means unobserved; negative disparity and single -1 are written."""
        arrays = synthetic_2019()
        proc, bag = self.convert(self.write_npz('old.npz', arrays))
        self.assert_converted(proc, bag)
        messages, _, _ = read_bag(bag)
        feature_msgs = [msg for msg, _ in messages[bag_writer.TOPIC_FEATURES]]
        self.assertEqual([[f.id for f in m.features] for m in feature_msgs],
                         [[0, 3], [0, 1, 3], [0, 1, 3], [1, 2, 3], [1, 3], []])
        negative = [f for f in feature_msgs[2].features if f.id == 1][0]
        self.assertEqual((negative.u_left, negative.u_right), (300.0, 320.0))
        partial = [f for f in feature_msgs[3].features if f.id == 2][0]
        self.assertEqual(partial.v_right, -1.0)
        self.assertEqual(feature_msgs[5].header.frame_id, 'camera_left')
        (left, _), (right, _) = (messages[bag_writer.TOPIC_LEFT_INFO][0],
                                 messages[bag_writer.TOPIC_RIGHT_INFO][0])
        self.assertEqual((left.width, left.height), (0, 0))   # no image_size in the file
        self.assertAlmostEqual(right.P[3], -simulator.KITTI_K[0, 0] * 0.54, places=9)


def _corrupt_member(path, member):
    """Overwrite bytes in the middle of one member's data, keeping the zip directory intact."""
    import zipfile
    with zipfile.ZipFile(path) as archive:
        info = archive.getinfo(member)
    with open(path, 'r+b') as f:
        f.seek(info.header_offset + 30 + len(info.filename) + info.compress_size // 2)
        f.write(b'\xff' * 16)


class ValidationTest(ConverterTestCase):
    """Every bad file: exit 2, one line naming the field, no traceback, nothing written."""

    def check(self, arrays, *needles):
        proc, bag = self.convert(self.write_npz('bad.npz', arrays))
        self.assert_clean_failure(proc, bag, 'bad.npz', *needles)
        with self.assertRaises(DatasetError):
            load_dataset(os.path.join(self.tmp, 'bad.npz'))

    def mutated(self, **changes):
        arrays = synthetic_2019()
        for key, value in changes.items():
            if value is None:
                del arrays[key]
            else:
                arrays[key] = value
        return arrays

    def test_missing_keys(self):
        for key in ('time_stamps', 'features', 'linear_velocity', 'rotational_velocity', 'K',
                    'b', 'cam_T_imu'):
            with self.subTest(key=key):
                self.check(self.mutated(**{key: None}), "missing field '%s'" % key)
        # The tracker's npz without --poses has no twist: the message says where one comes from.
        self.check(self.mutated(linear_velocity=None), 'only with --poses')

    def test_shape_mismatch(self):
        good = synthetic_2019()
        cases = {
            'features': good['features'][:, :, :5],
            'linear_velocity': good['linear_velocity'][:, :5],
            'rotational_velocity': good['rotational_velocity'][:2],
            'K': np.eye(4),
            'b': np.array([0.5, 0.5]),
            'cam_T_imu': good['cam_T_imu'][:3],
            'time_stamps': np.ones((2, 3)),
        }
        for key, value in cases.items():
            with self.subTest(key=key):
                self.check(self.mutated(**{key: value}), "field '%s'" % key, 'shape')

    def test_features_not_four_rows(self):
        self.check(self.mutated(features=-np.ones((3, 4, 6))), "field 'features'", 'shape')

    def test_non_finite_velocity(self):
        v = synthetic_2019()['linear_velocity']
        v[1, 3] = np.nan
        self.check(self.mutated(linear_velocity=v),
                   "field 'linear_velocity': non-finite value at frame 3")
        w = synthetic_2019()['rotational_velocity']
        w[2, 4] = np.inf
        self.check(self.mutated(rotational_velocity=w),
                   "field 'rotational_velocity': non-finite value at frame 4")

    def test_time_not_increasing(self):
        t = synthetic_2019()['time_stamps'].copy()
        t[0, 2] = t[0, 1]
        self.check(self.mutated(time_stamps=t), "field 'time_stamps'",
                   'not strictly increasing at frame 2')
        t = synthetic_2019()['time_stamps'][:, ::-1].copy()
        self.check(self.mutated(time_stamps=t), "field 'time_stamps'", 'frame 1')

    def test_intrinsics(self):
        for index, value in (((0, 0), 0.0), ((1, 1), -700.0), ((0, 2), np.nan)):
            K = simulator.KITTI_K.copy()
            K[index] = value
            with self.subTest(index=index, value=value):
                self.check(self.mutated(K=K), "field 'K'")

    def test_baseline(self):
        for value in (0.0, -0.54, np.nan):
            with self.subTest(value=value):
                self.check(self.mutated(b=np.array(value)), "field 'b'")

    def test_extrinsic(self):
        scaled = synthetic_2019()['cam_T_imu']
        scaled[:3, :3] *= 1.01
        reflected = synthetic_2019()['cam_T_imu']
        reflected[:3, 0] *= -1.0
        last_row = synthetic_2019()['cam_T_imu']
        last_row[3, 0] = 0.5
        for name, value, needle in (('scaled', scaled, 'orthonormal'),
                                    ('reflection', reflected, 'determinant'),
                                    ('last row', last_row, 'last row')):
            with self.subTest(case=name):
                self.check(self.mutated(cam_T_imu=value), "field 'cam_T_imu'", needle)
        later = synthetic_later()
        later['imu_T_cam'][:3, :3] *= 0.99
        self.check(later, "field 'imu_T_cam'", 'orthonormal')

    def test_dtypes(self):
        strings = np.array([['1', '2', '3']] * 3)
        self.check(self.mutated(K=strings), "field 'K'", 'not numeric')
        objects = np.empty((4, 4, 6), dtype=object)
        objects[:] = 1.0
        self.check(self.mutated(features=objects), "field 'features'", 'object array')

    def test_ambiguous_keys(self):
        arrays = synthetic_2019()
        arrays['imu_T_cam'] = se3.inverse(arrays['cam_T_imu'])
        self.check(arrays, "'cam_T_imu' and 'imu_T_cam'")

    def test_truncated_file(self):
        path = self.write_npz('whole.npz', synthetic_2019())
        with open(path, 'rb') as f:
            data = f.read()
        for name, size in (('half', len(data) // 2), ('tail cut', len(data) - 10),
                           ('empty', 0)):
            with self.subTest(case=name):
                bad = os.path.join(self.tmp, 'cut.npz')
                with open(bad, 'wb') as f:
                    f.write(data[:size])
                proc, bag = self.convert(bad)
                self.assert_clean_failure(proc, bag, 'cut.npz')

    def test_corrupt_member(self):
        path = os.path.join(self.tmp, 'corrupt.npz')
        np.savez_compressed(path, **synthetic_2019())
        _corrupt_member(path, 'features.npy')
        proc, bag = self.convert(path)
        self.assert_clean_failure(proc, bag, 'corrupt.npz', "field 'features'")

    def test_not_an_npz(self):
        text = os.path.join(self.tmp, 'text.npz')
        with open(text, 'w') as f:
            f.write('time_stamps,features\n1,2\n')
        proc, bag = self.convert(text)
        self.assert_clean_failure(proc, bag, 'text.npz')
        single = os.path.join(self.tmp, 'single.npy')
        np.save(single, np.zeros(3))
        proc, bag = self.convert(single)
        self.assert_clean_failure(proc, bag, 'single.npy')
        proc, bag = self.convert(os.path.join(self.tmp, 'missing.npz'))
        self.assert_clean_failure(proc, bag, 'missing.npz', 'no such file')

    def test_bad_groundtruth(self):
        npz = self.write_npz('good.npz', synthetic_2019())
        gt = os.path.join(self.tmp, 'gt.txt')
        with open(gt, 'w') as f:
            f.write('1 2 3\n')
        proc, bag = self.convert(npz, '--groundtruth', gt)
        self.assert_clean_failure(proc, bag, 'gt.txt')

    def test_usage_errors(self):
        npz = self.write_npz('good.npz', synthetic_2019())
        for args in ([npz], [npz, os.path.join(self.tmp, 'x.bag'), '--play'],
                     [npz, os.path.join(self.tmp, 'x.bag'), '--rate', '2']):
            with self.subTest(args=args[1:]):
                proc = ekf_test_paths.run_script(SCRIPT, *args)
                self.assertEqual(proc.returncode, 2)
                self.assertNotIn('Traceback', proc.stderr)
        self.assertEqual(glob.glob(os.path.join(self.tmp, '*.bag*')), [])

    def test_unwritable_output(self):
        npz = self.write_npz('good.npz', synthetic_2019())
        bag = os.path.join(self.tmp, 'no_such_dir', 'out.bag')
        proc = ekf_test_paths.run_script(SCRIPT, npz, bag)
        self.assertEqual(proc.returncode, 1)
        self.assertEqual(len(proc.stderr.strip().splitlines()), 1, proc.stderr)
        self.assertNotIn('Traceback', proc.stderr)

    def test_play_without_master(self):
        npz = self.write_npz('good.npz', synthetic_2019())
        env = ekf_test_paths.script_env()
        env['ROS_MASTER_URI'] = 'http://localhost:1'
        proc = ekf_test_paths.run_script(SCRIPT, npz, '--play', env=env, timeout=60)
        self.assertEqual(proc.returncode, 1, proc.stderr)
        self.assertIn('no ROS master', proc.stderr)
        self.assertNotIn('Traceback', proc.stderr)


class InterruptTest(ConverterTestCase):
    """Ctrl-C while writing leaves neither the bag nor its temporary file."""

    def test_keyboard_interrupt_removes_temp_file(self):
        dataset = load_dataset(self.write_npz('good.npz', synthetic_2019()))
        bag = os.path.join(self.tmp, 'out.bag')

        def interrupt(done, total):
            if done == 3:
                raise KeyboardInterrupt
        with self.assertRaises(KeyboardInterrupt):
            bag_writer.write_bag(dataset, bag, progress=interrupt)
        self.assertEqual(os.listdir(self.tmp), ['good.npz'])


LISTENER = r"""
import collections, json, sys, time
import rospy
from rosgraph_msgs.msg import Clock
from ekf_vislam_tools import bag_writer
expected = json.loads(sys.argv[1])
counts, clock = collections.Counter(), []
def counter(topic):
    return lambda msg: counts.update([topic])
rospy.init_node('play_listener', disable_signals=True)
for topic, msg_class in bag_writer.TOPIC_TYPES.items():
    rospy.Subscriber(topic, msg_class, counter(topic))
rospy.Subscriber('/clock', Clock, lambda msg: clock.append(msg.clock.to_sec()))
print('ready', flush=True)
deadline = time.time() + float(sys.argv[2])
while time.time() < deadline and any(counts[t] < n for t, n in expected.items()):
    time.sleep(0.05)
time.sleep(0.2)
print(json.dumps({'counts': counts, 'clock': clock}), flush=True)
"""


def free_port():
    with socket.socket() as s:
        s.bind(('localhost', 0))
        return s.getsockname()[1]


@unittest.skipIf(shutil.which('roscore') is None, 'roscore not installed')
class PlayTest(ConverterTestCase):
    """--play against a private roscore: every message arrives, /clock runs forward."""

    def start_roscore(self, env):
        core = subprocess.Popen(['roscore', '-p', env['ROS_MASTER_URI'].rsplit(':', 1)[1]],
                                env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                process_group=0)

        def stop():
            os.killpg(core.pid, signal.SIGINT)
            try:
                core.wait(timeout=15)
            except subprocess.TimeoutExpired:
                os.killpg(core.pid, signal.SIGKILL)
                core.wait()
        self.addCleanup(stop)
        check = [ekf_test_paths.PYTHON, '-c', 'import rosgraph, sys; '
                 'sys.exit(0 if rosgraph.is_master_online() else 1)']
        deadline = time.time() + 30
        while subprocess.run(check, env=env).returncode != 0:
            if time.time() > deadline or core.poll() is not None:
                self.fail('roscore did not come up')
            time.sleep(0.3)

    def test_play(self):
        sim = simulator.simulate(8, frames=30)
        paths = simulator.write_outputs(sim, os.path.join(self.tmp, 'sim'))
        env = ekf_test_paths.script_env()
        env['ROS_MASTER_URI'] = 'http://localhost:%d' % free_port()
        env['ROS_HOME'] = os.path.join(self.tmp, 'ros_home')
        self.start_roscore(env)
        expected = {topic: 30 for topic in SENSOR_TOPICS + (bag_writer.TOPIC_GROUNDTRUTH,)}
        expected[bag_writer.TOPIC_TF_STATIC] = 1
        listener = subprocess.Popen([ekf_test_paths.PYTHON, '-c', LISTENER, json.dumps(expected),
                                     '30'], env=env, stdout=subprocess.PIPE,
                                    universal_newlines=True)
        self.addCleanup(listener.wait)
        self.assertEqual(listener.stdout.readline().strip(), 'ready')
        proc = ekf_test_paths.run_script(SCRIPT, paths['npz'], '--play', '--rate', '5',
                                         '--groundtruth', paths['groundtruth'], env=env,
                                         timeout=60)
        self.assertEqual(proc.returncode, 0, proc.stderr)
        self.assertIn('played 30 frames', proc.stdout)
        report = json.loads(listener.stdout.readline())
        listener.stdout.close()
        self.assertEqual(report['counts'], expected)
        clock = np.array(report['clock'])
        self.assertGreater(clock.size, 30)
        self.assertTrue(np.all(np.diff(clock) > 0))
        self.assertAlmostEqual(clock[-1], sim['t'][-1], delta=1e-6)
        self.assertGreaterEqual(clock[0], sim['t'][0] - 1e-6)


@unittest.skipIf(ekf_test_paths.data_dir() is None, 'data directory absent (EKF_VISLAM_DATA)')
class RealDataTest(ConverterTestCase):
    """The course files in the shared data directory."""

    def test_0027_with_groundtruth(self):
        npz = ekf_test_paths.data_file('0027.npz')
        gt = ekf_test_paths.data_file('groundtruth', '0027_imu_gt.tum')
        if npz is None or gt is None:
            self.skipTest('0027.npz or its ground truth absent')
        proc, bag = self.convert(npz, '--groundtruth', gt)
        self.assert_converted(proc, bag)
        self.assertIn('corrected', proc.stderr)
        messages, _, _ = read_bag(bag)
        self.assertEqual(len(messages[bag_writer.TOPIC_TWIST]), 1106)
        self.assertEqual(len(messages[bag_writer.TOPIC_FEATURES]), 1106)
        self.assertEqual(len(messages[bag_writer.TOPIC_GROUNDTRUTH]), 1101)
        cam_T_imu = se3.inverse(transform_matrix(tf_by_child(messages)['camera_left'].transform))
        np.testing.assert_allclose(cam_T_imu[:3, 3], [-0.3164, 0.7341, -1.1380], atol=1e-3)
        first, _ = messages[bag_writer.TOPIC_GROUNDTRUTH][0]
        np.testing.assert_allclose(pose_matrix(first.pose.pose), np.eye(4), atol=1e-6)
        if shutil.which('rosbag'):
            info = subprocess.run(['rosbag', 'info', '--yaml', bag], stdout=subprocess.PIPE,
                                  universal_newlines=True, env=ekf_test_paths.script_env())
            self.assertIn('topic: /imu/twist', info.stdout)
            twist_block = info.stdout.split('topic: /imu/twist')[1]
            self.assertIn('messages: 1106', twist_block.split('topic:')[0])

    def test_kitti_poses_agree_with_tum(self):
        """KITTI world_T_cam0 + cam_T_imu, re-anchored, equals the TUM world_T_imu re-anchored."""
        npz = ekf_test_paths.data_file('0027.npz')
        tum = ekf_test_paths.data_file('groundtruth', '0027_imu_gt.tum')
        kitti = ekf_test_paths.data_file('groundtruth', 'kitti_odometry_07_poses.txt')
        if None in (npz, tum, kitti):
            self.skipTest('0027 ground truth files absent')
        dataset = load_dataset(npz)
        t_tum, from_tum = bag_writer.load_groundtruth(tum, dataset)
        t_kitti, from_kitti = bag_writer.load_groundtruth(kitti, dataset)
        n = min(len(t_tum), len(t_kitti))
        np.testing.assert_allclose(t_kitti[:n], t_tum[:n], atol=1e-3)
        np.testing.assert_allclose(from_kitti[:n, :3, 3], from_tum[:n, :3, 3], atol=5e-3)
        np.testing.assert_allclose(from_kitti[:n, :3, :3], from_tum[:n, :3, :3], atol=1e-4)
        proc, bag = self.convert(npz, '--groundtruth', kitti)
        self.assert_converted(proc, bag)
        messages, _, _ = read_bag(bag)
        self.assertEqual(len(messages[bag_writer.TOPIC_GROUNDTRUTH]), len(t_kitti))

    def test_03_later_layout(self):
        npz = ekf_test_paths.data_file('03.npz')
        if npz is None:
            self.skipTest('03.npz absent')
        proc, bag = self.convert(npz)
        self.assert_converted(proc, bag)
        # Its twist turns against its extrinsic (test_twist_axes): turned, and said once.
        self.assertEqual(len(proc.stderr.strip().splitlines()), 1, proc.stderr)
        self.assertIn('half turn about x', proc.stderr)
        messages, _, _ = read_bag(bag)
        for topic in SENSOR_TOPICS:
            self.assertEqual(len(messages[topic]), 1010, topic)
        with np.load(npz) as raw:
            imu_T_cam = raw['imu_T_cam']
            w = raw['angular_velocity'][:, 0]
        np.testing.assert_allclose(
            transform_matrix(tf_by_child(messages)['camera_left'].transform), imu_T_cam,
            atol=1e-6)
        a = messages[bag_writer.TOPIC_TWIST][0][0].twist.angular
        np.testing.assert_allclose([a.x, a.y, a.z], [w[0], -w[1], -w[2]], atol=1e-9)


if __name__ == '__main__':
    unittest.main()
