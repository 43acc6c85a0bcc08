#!/usr/bin/python3
"""Plays a fault-injected synthetic bag through the nodelet, then the clean bag again (time going
back; see vislam_faults.test)."""
import json
import math
import os
import shutil
import sys
import tempfile
import time
import unittest

import rosbag
import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticArray
from nav_msgs.msg import Odometry
from rosgraph_msgs.msg import Log
from sensor_msgs.msg import CameraInfo
from std_srvs.srv import Trigger

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from vislam_rostest import ESTIMATOR_INPUTS, PLAY_RATE, log, simulated_bag  # noqa: E402

from ekf_vislam_tools import metrics, trajectory  # noqa: E402
from ekf_vislam_tools.bag_playback import play_bag, wait_until  # noqa: E402
from ekf_vislam_tools.faults import inject_faults  # noqa: E402

PKG = 'ekf_vislam'
NODELET = '/vislam'
# Measured on this bag (seed 5, 300 frames, faults injected): ATE 0.072 m.
ATE_TOLERANCE_M = 1.0


class VislamFaultsTest(unittest.TestCase):
    @classmethod
    def play(cls, bag, name):
        """Plays `bag` into the nodelet, resumed once it is connected."""
        play_bag(bag, name, PLAY_RATE, {topic: ('/vislam_manager',) for topic in ESTIMATOR_INPUTS})

    @classmethod
    def wait_settled(cls):
        """Returns once no odometry has come for 1.5 s (20 s at most)."""
        last = [len(cls.odometry), time.time()]

        def settled():
            if len(cls.odometry) != last[0]:
                last[0], last[1] = len(cls.odometry), time.time()
            return time.time() - last[1] > 1.5
        wait_until(settled, 20.0)

    @classmethod
    def save(cls, folder):
        """~save into `folder`: (service response, stats.json)."""
        out = os.path.join(cls.tmp, folder)
        rospy.set_param(NODELET + '/ros/output_dir', out)
        response = rospy.ServiceProxy(NODELET + '/save', Trigger)()
        with open(os.path.join(out, 'stats.json')) as f:
            return out, response, json.load(f)

    @classmethod
    def on_diagnostics(cls, msg):
        for status in msg.status:
            if status.name.endswith('estimator'):
                cls.diagnostics = {kv.key: kv.value for kv in status.values}

    @classmethod
    def setUpClass(cls):
        rospy.init_node('vislam_faults_rostest', anonymous=True)
        cls.tmp = tempfile.mkdtemp(prefix='ekf_vislam_faults_')
        prefix = os.path.join(cls.tmp, 'sim')
        simulated_bag(prefix, 5, 300)
        cls.groundtruth = prefix + '_groundtruth.tum'
        cls.bag = os.path.join(cls.tmp, 'faulty.bag')
        cls.expected = inject_faults(prefix + '.bag', cls.bag)
        cls.odometry = []
        cls.diagnostics = {}
        cls.warnings = []  # the node's warnings (/rosout), subscribed before anything plays
        rospy.Subscriber('/rosout', Log, lambda msg: cls.warnings.append(msg.msg)
                         if msg.level == Log.WARN else None, queue_size=1000)
        rospy.Subscriber(NODELET + '/odometry', Odometry, cls.odometry.append, queue_size=10000)
        rospy.Subscriber('/diagnostics', DiagnosticArray, cls.on_diagnostics, queue_size=100)
        rospy.wait_for_service(NODELET + '/save', timeout=60.0)
        cls.play(cls.bag, '/vislam_faults_player')
        cls.wait_settled()
        cls.out, cls.save_response, cls.stats = cls.save('out')
        # The clean bag played afterwards: time goes back to the start of the drive.
        cls.play(prefix + '.bag', '/vislam_replay_player')
        cls.wait_settled()
        cls.replay_out, _, cls.replay_stats = cls.save('replay')
        wait_until(lambda: int(cls.diagnostics.get('time_jump_resets', 0)) > 0, 5.0)

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.tmp, ignore_errors=True)

    def test_node_alive_and_saving(self):
        self.assertTrue(self.save_response.success, self.save_response.message)
        self.assertGreater(len(self.odometry), 500)

    def test_only_finite_values_published(self):
        for msg in self.odometry:
            p, q = msg.pose.pose.position, msg.pose.pose.orientation
            values = [p.x, p.y, p.z, q.x, q.y, q.z, q.w] + list(msg.pose.covariance) + \
                [msg.twist.twist.linear.x, msg.twist.twist.angular.z] + list(msg.twist.covariance)
            self.assertTrue(all(math.isfinite(v) for v in values), 'non-finite odometry')
            self.assertAlmostEqual(q.x ** 2 + q.y ** 2 + q.z ** 2 + q.w ** 2, 1.0, places=6)

    def test_every_fault_class_is_counted(self):
        counters = self.stats['counters']
        for name, minimum in self.expected.items():
            self.assertGreaterEqual(counters[name], minimum, '%s: %s' % (name, counters))
        log('fault counters: %s' % {k: counters[k] for k in self.expected})
        # Faults, not gaps: no feature frame is missing from the stream's stamps.
        self.assertEqual(self.diagnostics.get('frames_missing'), '0', self.diagnostics)

    def ate(self, folder):
        t, T = trajectory.read_tum(os.path.join(folder, 'trajectory.tum'))
        tg, Tg = trajectory.read_tum(self.groundtruth)
        return metrics.evaluate_trajectory(t, T, tg, Tg)['ate_rmse_m'], len(t)

    def test_still_tracks_the_groundtruth(self):
        ate, _ = self.ate(self.out)
        log('ATE with faults: %.3f m' % ate)
        self.assertLess(ate, ATE_TOLERANCE_M)

    def test_time_going_back_restarts_the_estimator(self):
        """The second bag starts where the first did: the node resets once and tracks it anew
        (without the reset every frame of it would be stale and the trajectory the first's)."""
        self.assertGreaterEqual(int(self.diagnostics.get('time_jump_resets', 0)), 1,
                                self.diagnostics)
        ate, poses = self.ate(self.replay_out)
        log('replay after the time jump: %d poses, ATE %.3f m, %s time jump reset(s)' %
            (poses, ate, self.diagnostics.get('time_jump_resets')))
        # Counters run on across a reset: no frame of the replay was stale.
        self.assertEqual(self.replay_stats['counters']['frame_stale'],
                         self.stats['counters']['frame_stale'])
        self.assertEqual(self.replay_stats['time_jump_resets'], 1)
        self.assertGreater(poses, 250)
        self.assertLess(ate, ATE_TOLERANCE_M)

    def test_zz_a_changed_camera_info_is_ignored_and_warned(self):
        """A left camera_info with another focal length after the calibration was set: counted
        and warned, the estimator keeps its calibration. Runs last (the status stays WARN, below
        the stopped inputs' warning here)."""
        before = int(self.diagnostics.get('camera_info_changed', 0))
        warnings = [m for m in self.warnings if 'camera_info changed' in m]
        self.assertEqual(warnings, [])
        with rosbag.Bag(self.bag) as bag:
            info = next(msg for _, msg, _ in bag.read_messages(['/stereo/left/camera_info']))
        changed = CameraInfo()
        changed.header, changed.width, changed.height = info.header, info.width, info.height
        changed.K, changed.P = list(info.K), list(info.P)
        changed.P[0] += 5.0
        publisher = rospy.Publisher('/stereo/left/camera_info', CameraInfo, queue_size=10)
        wait_until(lambda: publisher.get_num_connections() > 0, 10.0)
        publisher.publish(changed)

        def warned():
            warnings[:] = [m for m in self.warnings if 'camera_info changed' in m]
            return warnings
        wait_until(lambda: int(self.diagnostics.get('camera_info_changed', 0)) > before and
                   warned(), 10.0)
        log('camera_info_changed %s; warned: %s' % (self.diagnostics.get('camera_info_changed'),
                                                    warnings))
        self.assertEqual(int(self.diagnostics['camera_info_changed']), before + 1)
        self.assertTrue(warnings)
        self.assertIn('fx 707.091 -> 712.091', warnings[0])
        self.assertEqual(self.diagnostics.get('calibration'), 'ok')


if __name__ == '__main__':
    rostest.rosrun(PKG, 'vislam_faults', VislamFaultsTest)
