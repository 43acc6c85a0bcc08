#!/usr/bin/python3
"""Convert a course dataset (npz) into a ROS bag for the estimator, or play it live.

    dataset_to_bag.py DATASET.npz OUT.bag [--groundtruth FILE] [--no-fix-extrinsic]
                      [--no-fix-twist-axes]
    dataset_to_bag.py DATASET.npz --play [--rate R] [--loop] [--groundtruth FILE]

The dataset is validated first (ekf_vislam_tools.dataset); a bad file ends with exit code 2 and
one line on stderr naming the field. Topics, frames and stamps: see ekf_vislam_tools.bag_writer.
A dataset with an accelerometer (specific_force) also gets /imu/data (sensor_msgs/Imu, its
linear_acceleration; with --twist-type imu_odometry in the gyro's messages).
--play needs a running roscore; it publishes /clock and the same topics in real time (times
--rate), for nodes running with /use_sim_time true (launch/play_npz.launch sets it).
"""
import argparse
import os
import sys
import time

import numpy as np

import rospy

from ekf_vislam_tools import bag_writer
from ekf_vislam_tools.dataset import (DatasetError, extrinsic_fix_notice, load_dataset,
                                      twist_axes_notice)
from ekf_vislam_tools.trajectory import TrajectoryError

PROG = 'dataset_to_bag.py'
EXIT_OK, EXIT_FAILURE, EXIT_BAD_INPUT, EXIT_INTERRUPTED = 0, 1, 2, 130

#: /clock is published at this wall-clock rate between messages while playing.
CLOCK_RATE_HZ = 100.0


class ToolFailure(RuntimeError):
    """The input is fine but the job cannot be done (bag not writable, no ROS master)."""


def parse_args(argv):
    parser = argparse.ArgumentParser(
        prog=PROG,
        description='Convert a course dataset (npz, 2019 or later layout) into a ROS bag with '
                    '/imu/twist, /stereo/features, /stereo/{left,right}/camera_info, /tf_static '
                    '(and /groundtruth/odometry; /imu/data with the accelerometer of a dataset '
                    'with specific_force), or publish it live with --play.')
    parser.add_argument('dataset', metavar='DATASET.npz', help='course dataset file')
    parser.add_argument('out', metavar='OUT.bag', nargs='?', help='bag to write (not with --play)')
    parser.add_argument('--groundtruth', metavar='FILE',
                        help='ground truth: TUM file of world_T_imu, or KITTI odometry poses '
                             '(world_T_cam0, one line per dataset frame); written as '
                             '/groundtruth/odometry with the first pose as the identity')
    parser.add_argument('--no-fix-extrinsic', dest='fix_extrinsic', action='store_false',
                        help='2019 layout: keep the stored (wrong) cam_T_imu translation instead '
                             'of correcting it to -R t')
    parser.add_argument('--no-fix-twist-axes', dest='fix_twist_axes', action='store_false',
                        help='keep the stored twist even when it turns the other way than the '
                             'images (by default such a twist is turned by a half turn about x '
                             'into the extrinsic\'s axes)')
    parser.add_argument('--twist-type',
                        choices=sorted(bag_writer.TWIST_TYPES) + [bag_writer.IMU_ODOMETRY],
                        default='twist_stamped',
                        help='message type of /imu/twist (default %(default)s; the estimator\'s '
                        'ros/twist_type must match); imu_odometry: no /imu/twist but /imu/data '
                        '(sensor_msgs/Imu) and /wheel/odometry (nav_msgs/Odometry of base_link, '
                        'with a lever arm in /tf_static), for the twist combiner')
    parser.add_argument('--twist-covariance', type=float, nargs=2, metavar=('V', 'W'),
                        help='with twist_with_covariance or odometry: a diagonal covariance of '
                        'per-sample std V m/s and W rad/s (default: all zero, none given)')
    parser.add_argument('--wheel-every', type=int, default=1, metavar='N',
                        help='imu_odometry: one wheel odometry sample every N gyro samples (a '
                        'wheel odometry slower than the gyro; default %(default)s)')
    parser.add_argument('--features-every', type=int, default=1, metavar='M',
                        help='one feature frame (and camera_info) every M twist samples (a camera '
                        'slower than the twist; default %(default)s)')
    parser.add_argument('--camera-delay', type=float, default=0.0, metavar='S',
                        help='stamp camera_info and features S s after their frame\'s twist: a '
                        'camera whose stamps lag (the estimator takes extrinsic/'
                        'camera_time_offset: -S); default %(default)s')
    parser.add_argument('--play', action='store_true',
                        help='publish live (needs roscore) instead of writing a bag')
    parser.add_argument('--rate', type=float, default=None,
                        help='--play: speed factor relative to real time (default 1.0)')
    parser.add_argument('--loop', action='store_true', help='--play: start again at the end')
    parser.add_argument('--delay', type=float, default=None,
                        help='--play: seconds to wait after advertising, so subscribers can '
                             'connect (default 0.5)')
    args = parser.parse_args(argv)
    if args.play and args.out:
        parser.error('give either OUT.bag or --play, not both')
    if not args.play and not args.out:
        parser.error('give OUT.bag to write a bag, or --play to publish live')
    if args.wheel_every < 1 or args.features_every < 1:
        parser.error('--wheel-every and --features-every must be at least 1')
    if args.wheel_every != 1 and args.twist_type != bag_writer.IMU_ODOMETRY:
        parser.error('--wheel-every needs --twist-type imu_odometry')
    if args.play and (args.wheel_every != 1 or args.features_every != 1):
        parser.error('--wheel-every and --features-every write bags only')
    if not args.play:
        for name in ('rate', 'delay'):
            if getattr(args, name) is not None:
                parser.error('--%s only applies with --play' % name)
        if args.loop:
            parser.error('--loop only applies with --play')
    args.rate = 1.0 if args.rate is None else args.rate
    args.delay = 0.5 if args.delay is None else args.delay
    if not args.rate > 0:
        parser.error('--rate must be positive')
    if not args.delay >= 0:
        parser.error('--delay must not be negative')
    return args


class ProgressBar(object):
    """A one-line progress bar on stderr, drawn only when stderr is a terminal."""

    def __init__(self, label, stream=sys.stderr, width=30):
        self.label, self.stream, self.width = label, stream, width
        self.enabled = stream.isatty()
        self.shown = -1

    def __call__(self, done, total):
        if not self.enabled or total <= 0:
            return
        percent = int(100 * done / total)
        if percent == self.shown and done != total:
            return
        self.shown = percent
        filled = self.width * done // total
        self.stream.write('\r%s [%s%s] %3d%% %d/%d' % (self.label, '#' * filled,
                                                       '.' * (self.width - filled),
                                                       percent, done, total))
        self.stream.flush()

    def close(self):
        if self.enabled and self.shown >= 0:
            self.stream.write('\n')
            self.stream.flush()


def play(dataset, groundtruth, rate, loop, delay, camera_delay=0.0):
    """Publish the dataset's messages live, paced by their stamps, with /clock; -> frames played."""
    import rosgraph
    from rosgraph_msgs.msg import Clock
    from sensor_msgs.msg import Imu

    if not rosgraph.is_master_online():
        raise ToolFailure('no ROS master at %s; start roscore first' % rosgraph.get_master_uri())
    rospy.init_node('dataset_player', anonymous=True)
    clock_pub = rospy.Publisher('/clock', Clock, queue_size=10)
    topic_types = dict(bag_writer.TOPIC_TYPES)
    if dataset.specific_force is not None:  # the accelerometer's /imu/data
        topic_types[bag_writer.TOPIC_IMU] = Imu
    pubs = {topic: rospy.Publisher(topic, msg_class, queue_size=100,
                                   latch=(topic == bag_writer.TOPIC_TF_STATIC))
            for topic, msg_class in topic_types.items()
            if groundtruth is not None or topic != bag_writer.TOPIC_GROUNDTRUTH}
    time.sleep(delay)

    t_first = bag_writer.first_stamp(dataset, camera_delay).to_sec()
    frames = 0
    while not rospy.is_shutdown():
        wall_start = time.monotonic()
        last_clock = None
        for topic, msg, stamp in bag_writer.iter_messages(dataset, groundtruth,
                                                          camera_delay=camera_delay):
            target = wall_start + (stamp.to_sec() - t_first) / rate
            while not rospy.is_shutdown():
                now = time.monotonic()
                if now >= target:
                    break
                sim_now = bag_writer.to_ros_time(t_first + (now - wall_start) * rate)
                if last_clock is None or sim_now > last_clock:
                    clock_pub.publish(Clock(clock=sim_now))
                    last_clock = sim_now
                time.sleep(min(target - now, 1.0 / CLOCK_RATE_HZ))
            if rospy.is_shutdown():
                return frames
            if last_clock is None or stamp > last_clock:
                clock_pub.publish(Clock(clock=stamp))
                last_clock = stamp
            pubs[topic].publish(msg)
            if topic == bag_writer.TOPIC_FEATURES:
                frames += 1
        if not loop:
            break
    return frames


def run(args):
    dataset = load_dataset(args.dataset, fix_extrinsic=args.fix_extrinsic,
                           fix_twist_axes=args.fix_twist_axes)
    groundtruth = None
    if args.groundtruth:
        groundtruth = bag_writer.load_groundtruth(args.groundtruth, dataset)
    if not args.play:
        out_dir = os.path.dirname(os.path.abspath(args.out))
        if not os.path.isdir(out_dir):
            raise ToolFailure('%s: cannot write the bag (no directory %s)' % (args.out, out_dir))
    # Everything is checked: now the notice, so that a failing run prints only its error.
    for notice, flag in ((extrinsic_fix_notice(dataset), '--no-fix-extrinsic'),
                         (twist_axes_notice(dataset), '--no-fix-twist-axes')):
        if notice:
            print('%s: note: %s; %s keeps it as stored' % (PROG, notice, flag), file=sys.stderr)

    if args.play:
        if args.twist_type != 'twist_stamped' or args.twist_covariance:
            raise ToolFailure('--play publishes geometry_msgs/TwistStamped only')
        frames = play(dataset, groundtruth, args.rate, args.loop, args.delay, args.camera_delay)
        print('%s: played %d frames of %s' % (PROG, frames, args.dataset))
        return EXIT_OK

    progress = ProgressBar(os.path.basename(args.out))
    try:
        summary = bag_writer.write_bag(dataset, args.out, groundtruth, progress=progress,
                                       twist_type=args.twist_type,
                                       twist_covariance=twist_covariance(args),
                                       wheel_every=args.wheel_every,
                                       features_every=args.features_every,
                                       camera_delay=args.camera_delay)
    except OSError as exc:
        raise ToolFailure('%s: cannot write the bag (%s)' % (args.out, exc.strerror or exc))
    finally:
        progress.close()
    print('%s: wrote %s' % (PROG, summary))
    return EXIT_OK


def twist_covariance(args):
    """The 6x6 covariance of --twist-covariance (None without it)."""
    if not args.twist_covariance:
        return None
    if args.twist_type == 'twist_stamped':
        raise ToolFailure('--twist-covariance needs --twist-type twist_with_covariance or odometry')
    v, w = args.twist_covariance
    return np.diag([v * v] * 3 + [w * w] * 3)


def main(argv=None):
    argv = rospy.myargv(sys.argv if argv is None else argv)[1:]  # drops roslaunch's __name:= etc.
    args = parse_args(argv)
    try:
        return run(args)
    except (DatasetError, TrajectoryError) as exc:
        print('%s: error: %s' % (PROG, exc), file=sys.stderr)
        return EXIT_BAD_INPUT
    except ToolFailure as exc:
        print('%s: error: %s' % (PROG, exc), file=sys.stderr)
        return EXIT_FAILURE
    except KeyboardInterrupt:
        print('%s: interrupted' % PROG, file=sys.stderr)
        return EXIT_INTERRUPTED


if __name__ == '__main__':
    sys.exit(main())
