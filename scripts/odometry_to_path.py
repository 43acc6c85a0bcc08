#!/usr/bin/python3
"""Accumulates nav_msgs/Odometry into a nav_msgs/Path (e.g. a ground truth for rviz).

    rosrun ekf_vislam odometry_to_path.py odometry:=/groundtruth/odometry path:=/groundtruth/path

Subscribes `odometry`, publishes `path` (latched) at most ~rate Hz (default 2); the path frame is
the odometry's header.frame_id. ~max_poses (default 0 = unlimited) keeps only the newest poses.
A jump back in time (a bag played again, /clock reset) starts a new path.
"""
import threading

import rospy
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Odometry, Path


class OdometryToPath:
    def __init__(self):
        self.rate = float(rospy.get_param('~rate', 2.0))
        self.max_poses = int(rospy.get_param('~max_poses', 0))
        self.lock = threading.Lock()
        self.path = Path()
        self.dirty = False
        self.pub = rospy.Publisher('path', Path, queue_size=1, latch=True)
        self.sub = rospy.Subscriber('odometry', Odometry, self.callback, queue_size=1000)
        if self.rate > 0.0:
            self.timer = rospy.Timer(rospy.Duration(1.0 / self.rate), self.publish)

    def callback(self, msg):
        pose = PoseStamped()
        pose.header = msg.header
        pose.pose = msg.pose.pose
        with self.lock:
            if self.path.poses and msg.header.stamp < self.path.poses[-1].header.stamp:
                self.path.poses = []
            self.path.header.frame_id = msg.header.frame_id
            self.path.header.stamp = msg.header.stamp
            self.path.poses.append(pose)
            if self.max_poses > 0 and len(self.path.poses) > self.max_poses:
                del self.path.poses[:len(self.path.poses) - self.max_poses]
            self.dirty = True

    def publish(self, _event=None):
        with self.lock:
            if not self.dirty:
                return
            self.dirty = False
            self.pub.publish(self.path)


def main():
    rospy.init_node('odometry_to_path')
    OdometryToPath()
    rospy.spin()


if __name__ == '__main__':
    main()
