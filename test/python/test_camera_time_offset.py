"""A camera whose stamps lag: dataset_to_bag.py --camera-delay stamps the camera's messages late,
and vislam_offline with extrinsic/camera_time_offset at minus that delay (read from --config) uses
each frame when its images were taken: the trajectory of the bag whose camera is in sync."""
import os
import unittest

import numpy as np
import rosbag

import ekf_test_paths as paths
from ekf_vislam_tools import package, simulator

DELAY = 0.05  # s


def trajectory(run_dir):
    return np.loadtxt(os.path.join(run_dir, 'trajectory.tum'), ndmin=2)


class CameraTimeOffsetTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        if package.vislam_offline_path() is None:
            raise unittest.SkipTest('vislam_offline not built')
        cls.tmp = paths.make_temp_dir()
        arrays = simulator.dataset_arrays(simulator.simulate(4, frames=150))
        npz = paths.write_npz(cls.tmp, 'drive.npz', arrays)
        cls.bags = {}
        for delay in (0.0, DELAY):
            bag = os.path.join(cls.tmp, 'drive_%g.bag' % delay)
            proc = paths.run_script('dataset_to_bag.py', npz, bag, '--camera-delay', delay)
            if proc.returncode != 0:
                raise AssertionError(proc.stderr)
            cls.bags[delay] = bag
        config = os.path.join(cls.tmp, 'offset.yaml')
        with open(config, 'w') as f:
            f.write('extrinsic:\n  camera_time_offset: %r\n' % -DELAY)
        cls.runs = {}
        for name, delay, args in (('in_sync', 0.0, ()), ('ignored', DELAY, ()),
                                  ('given', DELAY, ('--config', config))):
            out = os.path.join(cls.tmp, name)
            proc = paths.run_vislam_offline(cls.bags[delay], out, *args)
            if proc.returncode != 0:
                raise AssertionError(proc.stderr)
            cls.runs[name] = out

    @classmethod
    def tearDownClass(cls):
        paths.remove_dir(cls.tmp)

    def test_the_bag_stamps_the_camera_late(self):
        stamps = {}
        with rosbag.Bag(self.bags[DELAY]) as bag:
            for topic, msg, t in bag.read_messages(topics=['/imu/twist', '/stereo/features',
                                                           '/stereo/left/camera_info']):
                self.assertEqual(msg.header.stamp, t)
                stamps.setdefault(topic, []).append(t.to_sec())
        twist = np.array(stamps['/imu/twist'])
        self.assertEqual(len(twist), 150)
        for topic in ('/stereo/features', '/stereo/left/camera_info'):
            np.testing.assert_allclose(np.array(stamps[topic]) - twist, DELAY, atol=1e-6)

    def test_the_offset_gives_the_trajectory_of_the_camera_in_sync(self):
        in_sync, given = trajectory(self.runs['in_sync']), trajectory(self.runs['given'])
        self.assertEqual(in_sync.shape, (150, 8))
        self.assertEqual(given.shape, in_sync.shape)
        np.testing.assert_allclose(given[:, 0], in_sync[:, 0], rtol=0, atol=1e-6)
        self.assertLess(np.abs(given[:, 1:] - in_sync[:, 1:]).max(), 1e-9)

    def test_without_the_offset_the_poses_are_stamped_late(self):
        in_sync, ignored = trajectory(self.runs['in_sync']), trajectory(self.runs['ignored'])
        self.assertEqual(ignored.shape, in_sync.shape)
        np.testing.assert_allclose(ignored[:, 0] - in_sync[:, 0], DELAY, atol=1e-6)
        # Their positions are where the twist had carried the vehicle by the late stamps.
        self.assertGreater(np.abs(ignored[:, 1:4] - in_sync[:, 1:4]).max(), 0.1)


if __name__ == '__main__':
    unittest.main()
