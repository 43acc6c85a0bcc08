#!/usr/bin/python3
"""Plays a bag at 10x into the nodelet while pausing its process, then again with its twist
stream held back in wall time (see vislam_load.test)."""
import json
import os
import shutil
import signal
import sys
import tempfile
import threading
import time
import unittest
import xmlrpc.client

import numpy as np
import rosgraph
import rospkg
import rospy
import rostest
from std_srvs.srv import Trigger

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from vislam_rostest import (ESTIMATOR_INPUTS, DelayedRelay, log, read_tum, run,  # noqa: E402
                            run_script, simulated_bag)

from ekf_vislam_tools.bag_playback import resume_when_connected, start_player  # noqa: E402

PKG = 'ekf_vislam'
NODELET = '/vislam'
MANAGER = '/vislam_manager'
RATE = 10.0
PAUSES = 6
PAUSE_S = 0.5
# Wall seconds the twist stream is held back in the second play: 15 s of message time at 10x,
# beyond ros/sequencer_max_delay (10 s), which a frame waits for it in message time.
TWIST_DELAY_S = 1.5
EQUALITY_TOLERANCE_M = 1e-6


def data_dir(package):
    path = os.environ.get('EKF_VISLAM_DATA') or os.path.join(
        os.path.realpath(os.path.join(package, 'package.xml')), '..', '..', 'shared', 'data')
    path = os.path.normpath(path)
    return path if os.path.isfile(os.path.join(path, '0027.npz')) else None


def pid_of(node):
    uri = rosgraph.masterapi.Master('/vislam_load_rostest').lookupNode(node)
    return xmlrpc.client.ServerProxy(uri).getPid('/vislam_load_rostest')[2]


class LoadTest(unittest.TestCase):

    @classmethod
    def setUpClass(cls):
        rospy.init_node('vislam_load_rostest', anonymous=True)
        cls.tmp = tempfile.mkdtemp(prefix='ekf_vislam_load_')
        package = rospkg.RosPack().get_path(PKG)
        cls.bag = os.path.join(cls.tmp, 'drive.bag')
        data = data_dir(package)
        if data:
            cls.source = '0027'
            run_script('dataset_to_bag.py', os.path.join(data, '0027.npz'), cls.bag)
        else:
            cls.source = 'synthetic drive (no course data)'
            # As long as 0027 (110 s, 11 s at 10x): room for every pause (8.2 s).
            cls.bag = simulated_bag(os.path.join(cls.tmp, 'sim'), 4, 1100)
        log('playing %s at %gx with %d pauses of %g s' % (cls.source, RATE, PAUSES, PAUSE_S))
        cls.offline = os.path.join(cls.tmp, 'offline')
        log(run(['rosrun', PKG, 'vislam_offline', '--bag', cls.bag, '--out', cls.offline]).strip())
        rospy.wait_for_service(NODELET + '/save', timeout=60.0)
        cls.paused = []
        cls.live = {'paused': cls.play_paused(), 'late twist': cls.play_late_twist()}

    @classmethod
    def save(cls, name):
        folder = os.path.join(cls.tmp, name.replace(' ', '_'))
        rospy.set_param(NODELET + '/ros/output_dir', folder)
        response = rospy.ServiceProxy(NODELET + '/save', Trigger)()
        log(response.message)
        return folder

    @classmethod
    def play_paused(cls):
        """Plays the bag while the nodelet manager's process is stopped six times."""
        pid = pid_of(MANAGER)

        def pause_repeatedly(stop):
            time.sleep(1.0)
            for _ in range(PAUSES):
                if stop.is_set():
                    return
                os.kill(pid, signal.SIGSTOP)
                time.sleep(PAUSE_S)
                os.kill(pid, signal.SIGCONT)
                cls.paused.append(PAUSE_S)
                time.sleep(0.7)

        stop = threading.Event()
        pauser = threading.Thread(target=pause_repeatedly, args=(stop,))
        name = '/vislam_load_player'
        player = start_player(cls.bag, name, RATE)
        try:
            resume_when_connected(name, {topic: ('/vislam_manager',) for topic in ESTIMATOR_INPUTS})
            pauser.start()
            player.communicate(timeout=240)
        finally:
            stop.set()
            if pauser.is_alive():
                pauser.join()
            os.kill(pid, signal.SIGCONT)
            if player.poll() is None:
                player.kill()
        time.sleep(3.0)  # the nodelet works through what it received
        return cls.save('paused')

    @classmethod
    def play_late_twist(cls):
        """Plays the bag again (the nodelet is reset first) with imu/twist TWIST_DELAY_S behind."""
        response = rospy.ServiceProxy(NODELET + '/reset', Trigger)()
        log(response.message)
        relay = DelayedRelay('/imu/twist_recorded', '/imu/twist', TWIST_DELAY_S)
        try:
            required = {topic: ('/vislam_manager',) for topic in ESTIMATOR_INPUTS
                        if topic != '/imu/twist'}
            required['/imu/twist_recorded'] = (rospy.get_name(),)
            name = '/vislam_late_twist_player'
            player = start_player(cls.bag, name, RATE, ['/imu/twist:=/imu/twist_recorded'])
            relay.wait_for_subscriber()
            try:
                resume_when_connected(name, required)
                player.communicate(timeout=240)
            finally:
                if player.poll() is None:
                    player.kill()
            time.sleep(TWIST_DELAY_S + 3.0)  # the relay and the nodelet work through the rest
        finally:
            relay.close()
        return cls.save('late twist')

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.tmp, ignore_errors=True)

    def test_the_process_was_paused(self):
        self.assertEqual(len(self.paused), PAUSES)

    def test_nothing_rejected(self):
        offline = json.load(open(os.path.join(self.offline, 'stats.json')))
        frames_before = 0  # the counters add up over the plays (a reset keeps them)
        for play, folder in self.live.items():
            with self.subTest(play=play):
                live = json.load(open(os.path.join(folder, 'stats.json')))
                counters = live['counters']
                for name in ('frame_stale', 'twist_late', 'twist_time_not_increasing'):
                    self.assertEqual(counters[name], 0, name)
                self.assertEqual(live['sequencer_late'], 0)
                frames = counters['frame_used'] - frames_before
                frames_before = counters['frame_used']
                self.assertEqual(frames, offline['counters']['frame_used'])
                log('%s: %d frames, latency p50 %.2f ms, p99 %.2f ms' % (
                    play, frames, live['latency_ms_p50'], live['latency_ms_p99']))

    def test_live_equals_offline(self):
        t_off, off = read_tum(os.path.join(self.offline, 'trajectory.tum'))
        for play, folder in self.live.items():
            with self.subTest(play=play):
                t_live, live = read_tum(os.path.join(folder, 'trajectory.tum'))
                self.assertEqual(len(t_live), len(t_off))
                self.assertTrue(np.array_equal(t_live, t_off))
                difference = np.max(np.linalg.norm(live[:, :3] - off[:, :3], axis=1))
                log('%s, %s: max position difference live - offline %.3g m' % (
                    self.source, play, difference))
                self.assertLessEqual(difference, EQUALITY_TOLERANCE_M)


if __name__ == '__main__':
    rostest.rosrun(PKG, 'vislam_under_load', LoadTest)
