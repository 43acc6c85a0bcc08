"""dataset_to_bag.py with an accelerometer (specific_force): the /imu/data messages carry its
samples (in the gyro's messages with imu_odometry, in messages of their own with the other twist
types), datasets without it give the bags they always gave, and the field is validated."""
import hashlib
import os
import unittest

import numpy as np
import rosbag

import ekf_test_paths
from ekf_vislam_tools import bag_writer, simulator
from ekf_vislam_tools.dataset import DatasetError, load_dataset

SCRIPT = 'dataset_to_bag.py'

# Digests (`message_digest`) of the bags of `synthetic()` as written before the accelerometer
# existed: a dataset without specific_force must still give these messages (floats to DIGITS
# significant digits). Change them only with an intended change of the bags.
DIGITS = 9
DIGESTS_WITHOUT_ACCELEROMETER = {
    'twist_stamped': '25664122a6b447bd7fe55d8c404d6cf5f7924214008371f09da1406018a322a6',
    'odometry': 'cb2618dfa5ef7d093b37981bc41753b905c20bd7b55d7e755c5ef3a91c77be48',
    'imu_odometry': '75680b858a2151d945ecb3a00cf635bc84abf157404e6735476139149601dd75',
}
DIGEST_OPTIONS = {
    'twist_stamped': [],
    'odometry': ['--twist-type', 'odometry', '--twist-covariance', 0.5, 0.05],
    'imu_odometry': ['--twist-type', 'imu_odometry', '--twist-covariance', 0.5, 0.05,
                     '--wheel-every', 2, '--features-every', 3],
}


def synthetic(num=8):
    """A small dataset of known content (no random numbers), simulator layout."""
    k = np.arange(num, dtype=float)
    t = 1.3e9 + 0.1 * k + 0.001 * np.sin(k)
    features = -np.ones((4, 3, num))
    features[:, 0, 0:5] = [[600.0], [180.0], [590.0], [180.0]]
    features[:, 1, 2:8] = [[100.0], [50.0], [80.0], [50.5]]
    features[:, 2, 1:4] = [[900.0], [250.0], [880.0], [250.0]]
    cam_T_imu = np.eye(4)
    cam_T_imu[:3, :3] = [[0, -1, 0], [0, 0, -1], [1, 0, 0]]
    cam_T_imu[:3, 3] = [-0.3164, 0.7341, -1.1380]
    return {'time_stamps': t[None], 'features': features,
            'linear_velocity': np.stack([5.0 + k, 0.1 * k, -0.05 * k]),
            'rotational_velocity': np.stack([0.01 * k, -0.02 * k, 0.1 + 0.01 * k]),
            'K': np.array([[707.0912, 0, 601.8873], [0, 707.0912, 183.1104], [0, 0, 1.0]]),
            'b': np.array(0.54), 'cam_T_imu': cam_T_imu,
            'cam_T_imu_translation_correct': np.array(True), 'image_size': np.array([1241, 376])}


def with_accelerometer(arrays):
    """The dataset plus a specific_force of known, distinct values (m/s^2)."""
    num = arrays['time_stamps'].size
    k = np.arange(num, dtype=float)
    arrays = dict(arrays)
    arrays['specific_force'] = np.stack([0.1 * k - 0.3, 0.25 - 0.05 * k, 9.80665 + 0.01 * k])
    return arrays


def message_fields(msg, name=''):
    """(field path, value) of every leaf of a message, times as integer nanoseconds."""
    if hasattr(msg, 'to_nsec'):
        return [(name, msg.to_nsec())]
    if hasattr(msg, '__slots__'):
        return [leaf for slot in msg.__slots__
                for leaf in message_fields(getattr(msg, slot), name + '.' + slot)]
    if isinstance(msg, (list, tuple)):
        return [leaf for i, item in enumerate(msg) for leaf in message_fields(item, name + str(i))]
    return [(name, msg)]


def message_digest(path):
    """sha256 over every message of a bag: topic, time (ns), type and each field's value, floats
    to DIGITS significant digits. A CPU with another instruction set may give a float's last bits
    otherwise (numpy's vectorised transcendental functions differ by instruction set);
    float_margins() shows every value far from where that rounding would turn."""
    digest = hashlib.sha256()
    with rosbag.Bag(path) as bag:
        for topic, msg, stamp in bag.read_messages():
            digest.update(b'\0'.join([topic.encode(), str(stamp.to_nsec()).encode(),
                                      msg._type.encode()]))
            for name, value in message_fields(msg):
                text = ('%.*e' % (DIGITS - 1, value) if isinstance(value, float) else repr(value))
                digest.update(('\0%s=%s' % (name, text)).encode())
    return digest.hexdigest()


def float_margins(path):
    """The smallest distance, relative to the value, from any float of the bag to the midpoint
    where its DIGITS-digit rounding turns."""
    margins = [1.0]
    with rosbag.Bag(path) as bag:
        for _, msg, _ in bag.read_messages():
            for _, value in message_fields(msg):
                if isinstance(value, float) and value != 0 and np.isfinite(value):
                    exponent = np.floor(np.log10(abs(value))) - (DIGITS - 1)
                    scaled = abs(value) / 10.0 ** exponent
                    margins.append(abs(scaled - np.floor(scaled) - 0.5) / scaled)
    return min(margins)


def read_bag(path):
    """-> (topic -> [(msg, bag time)], [topic in bag order])."""
    messages, order = {}, []
    with rosbag.Bag(path) as bag:
        for topic, msg, stamp in bag.read_messages():
            messages.setdefault(topic, []).append((msg, stamp))
            order.append(topic)
    return messages, order


def vector(v):
    return [v.x, v.y, v.z]


class AccelerometerBagTest(unittest.TestCase):

    def setUp(self):
        self.tmp = ekf_test_paths.make_temp_dir(self)

    def convert(self, arrays, *options, name='d'):
        npz = ekf_test_paths.write_npz(self.tmp, name + '.npz', arrays)
        bag = os.path.join(self.tmp, name + '.bag')
        proc = ekf_test_paths.run_script(SCRIPT, npz, bag, *options)
        self.assertEqual(proc.returncode, 0, proc.stderr)
        return bag

    def test_without_accelerometer_the_bags_are_as_before(self):
        for case, options in DIGEST_OPTIONS.items():
            with self.subTest(twist_type=case):
                bag = self.convert(synthetic(), *options, name=case)
                self.assertEqual(message_digest(bag), DIGESTS_WITHOUT_ACCELEROMETER[case])
                # Last-bit differences (about 1e-15 relative) cannot turn a rounding.
                self.assertGreater(float_margins(bag), 1e-12)
        messages, _ = read_bag(os.path.join(self.tmp, 'twist_stamped.bag'))
        self.assertNotIn(bag_writer.TOPIC_IMU, messages)
        messages, _ = read_bag(os.path.join(self.tmp, 'imu_odometry.bag'))
        imu, _ = messages[bag_writer.TOPIC_IMU][0]
        self.assertEqual(imu.linear_acceleration_covariance[0], -1.0)   # ROS: no data
        self.assertEqual(vector(imu.linear_acceleration), [0.0, 0.0, 0.0])

    def test_other_twist_types_get_an_imu_message_per_frame(self):
        arrays = with_accelerometer(synthetic())
        force, t = arrays['specific_force'], arrays['time_stamps'][0]
        for twist_type in sorted(bag_writer.TWIST_TYPES):
            with self.subTest(twist_type=twist_type):
                bag = self.convert(arrays, '--twist-type', twist_type, name=twist_type)
                messages, order = read_bag(bag)
                sensors = [topic for topic in order if topic != bag_writer.TOPIC_TF_STATIC]
                self.assertEqual(sensors, [bag_writer.TOPIC_TWIST, bag_writer.TOPIC_IMU,
                                           bag_writer.TOPIC_LEFT_INFO, bag_writer.TOPIC_RIGHT_INFO,
                                           bag_writer.TOPIC_FEATURES] * t.size)
                imus = messages[bag_writer.TOPIC_IMU]
                for k, (imu, stamp) in enumerate(imus):
                    self.assertEqual(imu.header.stamp, stamp)
                    self.assertEqual(stamp, messages[bag_writer.TOPIC_TWIST][k][1])
                    self.assertAlmostEqual(stamp.to_sec(), t[k], delta=1e-6)
                    self.assertEqual(imu.header.frame_id, 'imu')
                    np.testing.assert_array_equal(vector(imu.linear_acceleration), force[:, k])
                    self.assertEqual(list(imu.linear_acceleration_covariance), [0.0] * 9)
                    self.assertEqual(imu.orientation_covariance[0], -1.0)
                    self.assertEqual(imu.angular_velocity_covariance[0], -1.0)
                    self.assertEqual(vector(imu.angular_velocity), [0.0, 0.0, 0.0])
                # Every other message as without the accelerometer.
                plain, _ = read_bag(self.convert(synthetic(), '--twist-type', twist_type,
                                                 name=twist_type + '_plain'))
                self.assertEqual(set(messages) - set(plain), {bag_writer.TOPIC_IMU})
                for topic, msgs in plain.items():
                    self.assertEqual(msgs, messages[topic], topic)

    def test_imu_odometry_carries_the_sample_of_each_gyro_stamp(self):
        arrays = with_accelerometer(synthetic())
        force, t = arrays['specific_force'], arrays['time_stamps'][0]
        # A slower wheel odometry and camera: still one accelerometer sample per gyro message.
        bag = self.convert(arrays, '--twist-type', 'imu_odometry', '--twist-covariance', 0.5,
                           0.05, '--wheel-every', 2, '--features-every', 3)
        messages, _ = read_bag(bag)
        self.assertNotIn(bag_writer.TOPIC_TWIST, messages)
        imus = messages[bag_writer.TOPIC_IMU]
        self.assertEqual(len(imus), t.size)
        self.assertEqual(len(messages[bag_writer.TOPIC_WHEEL_ODOMETRY]), 4)
        self.assertEqual(len(messages[bag_writer.TOPIC_FEATURES]), 3)
        for k, (imu, stamp) in enumerate(imus):
            self.assertAlmostEqual(stamp.to_sec(), t[k], delta=1e-6)
            np.testing.assert_array_equal(vector(imu.linear_acceleration), force[:, k])
            self.assertEqual(list(imu.linear_acceleration_covariance), [0.0] * 9)
            np.testing.assert_allclose(vector(imu.angular_velocity),
                                       arrays['rotational_velocity'][:, k], atol=1e-12)
            np.testing.assert_allclose(np.diag(np.reshape(imu.angular_velocity_covariance,
                                                          (3, 3))), [0.0025] * 3)
            self.assertEqual(imu.orientation_covariance[0], -1.0)
        # Apart from the accelerometer, the messages of the bag without it.
        plain, _ = read_bag(self.convert(synthetic(), '--twist-type', 'imu_odometry',
                                         '--twist-covariance', 0.5, 0.05, '--wheel-every', 2,
                                         '--features-every', 3, name='plain'))
        self.assertEqual(set(plain), set(messages))
        for topic, msgs in plain.items():
            if topic != bag_writer.TOPIC_IMU:
                self.assertEqual(msgs, messages[topic], topic)
        for (with_it, _), (without, _) in zip(imus, plain[bag_writer.TOPIC_IMU]):
            without.linear_acceleration = with_it.linear_acceleration
            without.linear_acceleration_covariance = with_it.linear_acceleration_covariance
            self.assertEqual(with_it, without)

    def test_simulated_drive(self):
        sim = simulator.simulate(6, frames=20, accel_noise=0.05)
        npz = simulator.write_outputs(sim, os.path.join(self.tmp, 'sim'))['npz']
        bag = os.path.join(self.tmp, 'sim.bag')
        proc = ekf_test_paths.run_script(SCRIPT, npz, bag)
        self.assertEqual(proc.returncode, 0, proc.stderr)
        messages, _ = read_bag(bag)
        got = np.array([vector(m.linear_acceleration) for m, _ in messages[bag_writer.TOPIC_IMU]])
        np.testing.assert_array_equal(got.T, sim['specific_force'])

    def test_validation(self):
        good = with_accelerometer(synthetic())
        dataset = load_dataset(ekf_test_paths.write_npz(self.tmp, 'good.npz', good))
        np.testing.assert_array_equal(dataset.specific_force, good['specific_force'])
        self.assertEqual(dataset.specific_force.dtype, np.float64)
        self.assertIsNone(load_dataset(ekf_test_paths.write_npz(self.tmp, 'plain.npz',
                                                                synthetic())).specific_force)
        non_finite = good['specific_force'].copy()
        non_finite[2, 5] = np.nan
        for value, needles in ((good['specific_force'][:, :7], ['shape', '(3, 8)']),
                               (good['specific_force'][:2], ['shape']),
                               (non_finite, ['non-finite value at frame 5']),
                               (np.array([['a'] * 8] * 3), ['not numeric'])):
            with self.subTest(needles=needles):
                arrays = dict(good, specific_force=value)
                npz = ekf_test_paths.write_npz(self.tmp, 'bad.npz', arrays)
                with self.assertRaises(DatasetError) as caught:
                    load_dataset(npz)
                for needle in ["field 'specific_force'"] + needles:
                    self.assertIn(needle, str(caught.exception))
                bag = os.path.join(self.tmp, 'bad.bag')
                proc = ekf_test_paths.run_script(SCRIPT, npz, bag)
                self.assertEqual(proc.returncode, 2, proc.stderr)
                self.assertIn("field 'specific_force'", proc.stderr)
                self.assertFalse(os.path.exists(bag))


if __name__ == '__main__':
    unittest.main()
