#!/usr/bin/python3
"""Plays a fault-injected synthetic bag through the nodelet (see vislam_faults.test)."""
import json
import math
import os
import shutil
import sys
import tempfile
import time
import unittest

import rospkg
import rospy
import rostest
from nav_msgs.msg import Odometry
from std_srvs.srv import Trigger

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from vislam_rostest import ESTIMATOR_INPUTS, PLAY_RATE, log, run  # noqa: E402

from ekf_vislam_tools import metrics, trajectory  # noqa: E402
from ekf_vislam_tools.bag_playback import play_bag, wait_until  # noqa: E402
from ekf_vislam_tools.faults import inject_faults  # noqa: E402

PKG = 'ekf_vislam'
NODELET = '/vislam'
# Measured on this bag (seed 5, 300 frames, faults injected): ATE 0.072 m.
ATE_TOLERANCE_M = 1.0


class VislamFaultsTest(unittest.TestCase):
    @classmethod
    def play(cls):
        """Plays the bag into the nodelet, resumed once it is connected."""
        play_bag(cls.bag, '/vislam_faults_player', PLAY_RATE,
                 {topic: ('/vislam_manager',) for topic in ESTIMATOR_INPUTS})

    @classmethod
    def setUpClass(cls):
        rospy.init_node('vislam_faults_rostest', anonymous=True)
        cls.tmp = tempfile.mkdtemp(prefix='ekf_vislam_faults_')
        package = rospkg.RosPack().get_path(PKG)
        prefix = os.path.join(cls.tmp, 'sim')
        run(['/usr/bin/python3', os.path.join(package, 'scripts', 'simulate_dataset.py'),
             '--seed', '5', '--out', prefix, '--frames', '300'])
        run(['/usr/bin/python3', os.path.join(package, 'scripts', 'dataset_to_bag.py'),
             prefix + '.npz', prefix + '.bag'])
        cls.groundtruth = prefix + '_groundtruth.tum'
        cls.bag = os.path.join(cls.tmp, 'faulty.bag')
        cls.expected = inject_faults(prefix + '.bag', cls.bag)
        cls.odometry = []
        rospy.Subscriber(NODELET + '/odometry', Odometry, cls.odometry.append, queue_size=10000)
        rospy.wait_for_service(NODELET + '/save', timeout=60.0)
        cls.play()
        last = [len(cls.odometry), time.time()]

        def settled():
            if len(cls.odometry) != last[0]:
                last[0], last[1] = len(cls.odometry), time.time()
            return time.time() - last[1] > 1.5
        wait_until(settled, 20.0)
        cls.out = os.path.join(cls.tmp, 'out')
        rospy.set_param(NODELET + '/ros/output_dir', cls.out)
        cls.save_response = rospy.ServiceProxy(NODELET + '/save', Trigger)()
        with open(os.path.join(cls.out, 'stats.json')) as f:
            cls.stats = json.load(f)

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

    def test_still_tracks_the_groundtruth(self):
        t, T = trajectory.read_tum(os.path.join(self.out, 'trajectory.tum'))
        tg, Tg = trajectory.read_tum(self.groundtruth)
        ate = metrics.evaluate_trajectory(t, T, tg, Tg)['ate_rmse_m']
        log('ATE with faults: %.3f m' % ate)
        self.assertLess(ate, ATE_TOLERANCE_M)


if __name__ == '__main__':
    rostest.rosrun(PKG, 'vislam_faults', VislamFaultsTest)
