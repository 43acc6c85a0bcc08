#!/usr/bin/python3
"""Plays a synthetic drive with a gyro and a wheel odometry instead of a twist through the twist
combiner and the estimator publishing for base_link (see ground_robot.test): live = offline, the
combined twist is the drive's own, odometry and tf are base_link's."""
import json
import os
import shutil
import sys
import tempfile
import time
import unittest

import numpy as np
import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import TwistWithCovarianceStamped
from nav_msgs.msg import Odometry
from std_srvs.srv import Trigger
from tf2_msgs.msg import TFMessage

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from vislam_rostest import (EQUALITY_TOLERANCE_M, PLAY_RATE, log, read_tum, run,  # noqa: E402
                            run_script, simulated_drive)

from ekf_vislam_tools import bag_writer, se3  # noqa: E402
from ekf_vislam_tools.bag_playback import play_bag, wait_until  # noqa: E402

PKG = 'ekf_vislam'
SEED = 3
FRAMES = 300
INPUTS = ('/imu/data', '/wheel/odometry', '/stereo/features', '/stereo/left/camera_info',
          '/stereo/right/camera_info')
#: The /body pipeline's subscribers of each input (standalone nodes): the estimator also takes
#: the accelerometer of /imu/data.
BODY_NODES = {topic: ('/body/twist_combiner',) if topic in INPUTS[:2] else ('/body/vislam',)
              for topic in INPUTS}
BODY_NODES['/imu/data'] += ('/body/vislam',)


def pose_matrix(position, orientation):
    T = np.eye(4)
    T[:3, :3] = se3.quaternion_to_rotation([orientation.x, orientation.y, orientation.z,
                                            orientation.w])
    T[:3, 3] = [position.x, position.y, position.z]
    return T


class GroundRobotTest(unittest.TestCase):
    @classmethod
    def on_diagnostics(cls, msg):
        for status in msg.status:
            pipeline = 'body' if 'body' in status.name else 'main'
            if status.name.endswith('twist combiner'):
                cls.statuses.setdefault(pipeline, []).append(status)
            elif status.name.endswith('estimator'):
                cls.estimator_statuses.setdefault(pipeline, []).append(status)

    @classmethod
    def setUpClass(cls):
        rospy.init_node('ground_robot_rostest', anonymous=True)
        cls.tmp = tempfile.mkdtemp(prefix='ekf_vislam_ground_robot_')
        prefix = os.path.join(cls.tmp, 'sim')
        simulated_drive(prefix, SEED, FRAMES, '--accel-noise', 0.05)
        cls.bags = {}
        for kind, twist_type in (('direct', 'twist_stamped'), ('combined', 'imu_odometry')):
            cls.bags[kind] = os.path.join(cls.tmp, kind + '.bag')
            run_script('dataset_to_bag.py', prefix + '.npz', cls.bags[kind], '--twist-type',
                       twist_type)
            log(run(['rosrun', PKG, 'vislam_offline', '--bag', cls.bags[kind], '--out',
                     os.path.join(cls.tmp, 'offline_' + kind)]).strip())
        log(run(['rosrun', PKG, 'vislam_offline', '--bag', cls.bags['combined'], '--imu-frame',
                 'base_link', '--out', os.path.join(cls.tmp, 'offline_body')]).strip())
        cls.statuses, cls.twists, cls.updates, cls.tf = {}, [], [], []
        cls.estimator_statuses = {}
        counted = [rospy.Subscriber('/vislam/odometry_update', Odometry, cls.updates.append,
                                    queue_size=5000)]
        rospy.Subscriber('/tf', TFMessage, lambda msg: cls.tf.extend(msg.transforms),
                         queue_size=5000)
        rospy.Subscriber('/diagnostics', DiagnosticArray, cls.on_diagnostics, queue_size=100)
        counted.append(rospy.Subscriber('/imu/twist', TwistWithCovarianceStamped,
                                        cls.twists.append, queue_size=5000))
        cls.body_twists = []
        counted.append(rospy.Subscriber('/body/imu/twist', TwistWithCovarianceStamped,
                                        cls.body_twists.append, queue_size=5000))
        for service in ('/vislam/save', '/body/vislam/save'):
            rospy.wait_for_service(service, timeout=60.0)
        # Every tf listener connected too: the start does not depend on how fast /tf_static's
        # connections come up (the nodes would wait for it anyway, ros/tf_wait).
        required = {topic: ('/vislam_manager',) + BODY_NODES[topic] for topic in INPUTS}
        required['/tf_static'] = ('/vislam_manager',) + tuple(
            sorted({node for nodes in BODY_NODES.values() for node in nodes}))
        play_bag(cls.bags['combined'], '/ground_robot_player', PLAY_RATE, required,
                 listening=counted)
        wait_until(lambda: len(cls.twists) >= FRAMES and len(cls.body_twists) >= FRAMES, 30.0)
        time.sleep(2.0)  # the estimator processes the last frame; one more diagnostics period
        for node, folder in (('/vislam', 'live'), ('/body/vislam', 'live_body')):
            rospy.set_param(node + '/ros/output_dir', os.path.join(cls.tmp, folder))
            response = rospy.ServiceProxy(node + '/save', Trigger)()
            if not response.success:
                raise RuntimeError('%s/save failed: %s' % (node, response.message))

    @classmethod
    def tearDownClass(cls):
        if not os.environ.get('EKF_VISLAM_KEEP_TEST_OUTPUT'):
            shutil.rmtree(cls.tmp, ignore_errors=True)

    def trajectory(self, folder):
        return read_tum(os.path.join(self.tmp, folder, 'trajectory.tum'))

    def test_every_gyro_sample_gives_a_twist_in_the_imu_frame(self):
        self.assertEqual(len(self.twists), FRAMES)
        self.assertTrue(all(msg.header.frame_id == 'imu' for msg in self.twists))

    def test_offline_stats_count_the_combiner(self):
        stats = json.load(open(os.path.join(self.tmp, 'offline_combined', 'stats.json')))
        self.assertEqual(stats['twist_combiner_gyro_samples'], FRAMES)
        self.assertEqual(stats['twist_combiner_twists'], FRAMES)
        self.assertEqual(stats['twist_combiner_velocity_held'], 0)
        direct = json.load(open(os.path.join(self.tmp, 'offline_direct', 'stats.json')))
        self.assertNotIn('twist_combiner_twists', direct)

    def assertSameTrajectory(self, folder, reference, label, tolerance=EQUALITY_TOLERANCE_M):
        """Same stamps, positions within `tolerance` m."""
        t, positions = self.trajectory(folder)
        t_reference, reference_positions = self.trajectory(reference)
        self.assertEqual(len(t), FRAMES)
        np.testing.assert_array_equal(t, t_reference)
        difference = np.abs(positions[:, :3] - reference_positions[:, :3]).max()
        log('%s: %.2e m' % (label, difference))
        self.assertLess(difference, tolerance)

    def test_the_accelerometer_holds_the_tilt_live_and_offline(self):
        # The drive's Imu messages carry an accelerometer: both estimators and every offline
        # run take it (gravity/, on by default), live as offline.
        for folder in ('offline_direct', 'offline_combined', 'offline_body', 'live'):
            with open(os.path.join(self.tmp, folder, 'stats.json')) as f:
                counters = json.load(f)['counters']
            self.assertEqual(counters['accel_used'], FRAMES, folder)
            self.assertGreater(counters['gravity_update'], 20, folder)
            for key in ('accel_implausible', 'accel_late', 'accel_non_finite',
                        'gravity_window_incomplete'):
                self.assertEqual(counters[key], 0, '%s %s' % (folder, key))
        self.assertEqual(set(self.estimator_statuses), {'main', 'body'}, 'estimator statuses')
        for pipeline, statuses in self.estimator_statuses.items():
            values = {kv.key: kv.value for kv in statuses[-1].values}
            self.assertEqual(int(values['accel_received']), FRAMES, pipeline)
            self.assertEqual(int(values['accel_without_tf']), 0, pipeline)
            self.assertEqual(int(values['accel_without_data']), 0, pipeline)

    def test_offline_combined_twist_matches_the_drive_twist(self):
        # The same twists, but with the noise the combiner estimates from each stream instead of
        # the estimator's own online estimate: 0.019 m apart at most over the 222 m drive.
        self.assertSameTrajectory('offline_combined', 'offline_direct',
                                  'offline: combined twist against the drive\'s own', 0.05)

    def test_live_equals_offline(self):
        self.assertSameTrajectory('live', 'offline_combined', 'live against offline')

    def test_base_link_as_the_body_live_equals_offline(self):
        self.assertSameTrajectory('live_body', 'offline_body',
                                  'base_link as the body, live against offline')

    def test_odometry_and_tf_are_the_base_frame_s(self):
        t_offline, offline = self.trajectory('offline_combined')
        self.assertEqual(len(self.updates), FRAMES)
        self.assertTrue(all(msg.child_frame_id == 'base_link' for msg in self.updates))
        children = {t.child_frame_id for t in self.tf if t.header.frame_id == 'world'}
        self.assertEqual(children, {'base_link'})
        worst = 0.0
        for msg in self.updates:
            k = int(np.argmin(np.abs(t_offline - msg.header.stamp.to_sec())))
            world_T_imu = np.eye(4)
            world_T_imu[:3, :3] = se3.quaternion_to_rotation(offline[k, 3:])
            world_T_imu[:3, 3] = offline[k, :3]
            expected = world_T_imu @ bag_writer.IMU_T_BASE
            actual = pose_matrix(msg.pose.pose.position, msg.pose.pose.orientation)
            worst = max(worst, np.abs(actual - expected).max())
        log('base_link odometry against the offline IMU poses moved by imu_T_base: %.2e' % worst)
        self.assertLess(worst, 1e-6)

    def test_diagnostics_count_the_inputs(self):
        self.assertEqual(set(self.statuses), {'main', 'body'}, 'twist combiner statuses')
        for pipeline, statuses in self.statuses.items():
            values = {kv.key: kv.value for kv in statuses[-1].values}
            for key in ('imu_received', 'odometry_received', 'twists_published'):
                self.assertEqual(int(values[key]), FRAMES, '%s %s' % (pipeline, key))
            for key in ('velocity_held', 'dropped_no_velocity', 'rejected_non_finite',
                        'imu_without_tf', 'odometry_without_tf'):
                self.assertEqual(int(values[key]), 0, '%s %s' % (pipeline, key))


if __name__ == '__main__':
    rostest.rosrun(PKG, 'ground_robot', GroundRobotTest)
