#!/usr/bin/python3
"""Publish a stereo image folder (KITTI odometry layout) as a live stereo stream, or write it as
a bag: what a stereo camera driver with rectification and a twist source would give.

    play_stereo_images.py FOLDER --bag OUT.bag [--max-frames N] [--poses FILE]
    play_stereo_images.py FOLDER --play [--rate R] [--loop] [--poses FILE]
    add --compressed png|jpeg [--jpeg-quality Q] for sensor_msgs/CompressedImage on
    /stereo/{left,right}/image_rect/compressed instead (the tracker's ros/image_transport
    compressed)
    add --raw-camera for the images a calibrated raw rig would give before rectification, on
    /stereo/{left,right}/image_raw, with its camera_info (K, D, R, P: the tracker's
    ros/rectify; ekf_vislam_tools.raw_camera): lenses with a barrel distortion, each camera
    turned from its rectified one by under a degree; the tf gives the raw left camera
    (--distortion-model rational_polynomial or equidistant for other lenses)

FOLDER holds image_left/ and image_right/ (or KITTI's image_0/ and image_1/), calib.txt (P0,
P1), times.txt and optionally poses.txt (world_T_cam0 per line; --poses FILE for poses kept
elsewhere, as KITTI's poses/NN.txt). Topics: /stereo/left/image_rect and /stereo/right/image_rect
(sensor_msgs/Image, mono8, frames camera_left / camera_right), /stereo/{left,right}/camera_info
(rectified, right P[0,3] = -fx b), and with poses /imu/twist (the ground-truth body twist of a
vehicle frame at the left camera, x along the poses' direction of travel, y left, z up, with the
noise of an accurate twist:
--twist-noise V W, --gyro-offset B, --seed N, as track_stereo_images), /tf_static imu ->
camera_left -> camera_right and /groundtruth/odometry. Stamps are the folder's times plus
--start-time (default 1000 s: ROS reads a zero stamp as "no time"). --play needs a roscore and
publishes /clock (run the nodes with /use_sim_time true).
"""
import argparse
import collections
import sys
import time

import cv2
import numpy as np
import rosbag
import rospy
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import CompressedImage, Image

from ekf_vislam_tools import bag_writer, raw_camera, stereo_images

PROG = 'play_stereo_images.py'
TOPIC_LEFT_IMAGE = '/stereo/left/image_rect'
TOPIC_RIGHT_IMAGE = '/stereo/right/image_rect'

# The fields bag_writer's message builders read.
_Calibration = collections.namedtuple('_Calibration', ['K', 'b', 'cam_T_imu', 'image_size', 'v',
                                                       'w'])


def parse_args(argv):
    p = argparse.ArgumentParser(prog=PROG, description=__doc__.split('\n\n')[0])
    p.add_argument('folder')
    out = p.add_mutually_exclusive_group(required=True)
    out.add_argument('--bag', help='write this bag')
    out.add_argument('--play', action='store_true', help='publish live (needs a roscore)')
    p.add_argument('--rate', type=float, default=1.0, help='--play speed factor (default 1)')
    p.add_argument('--loop', action='store_true', help='--play: start over at the end')
    p.add_argument('--max-frames', type=int, default=0, help='only the first N frames')
    p.add_argument('--poses', help='world_T_cam0 per line (default: FOLDER/poses.txt if any)')
    p.add_argument('--start-time', type=float, default=1000.0, help='s added to every time')
    p.add_argument('--twist-noise', type=float, nargs=2, default=(0.05, 0.005),
                   metavar=('V', 'W'), help='white twist noise, m/s and rad/s per sample and axis')
    p.add_argument('--gyro-offset', type=float, default=0.001, help='rad/s on every gyro axis')
    p.add_argument('--seed', type=int, default=0)
    p.add_argument('--no-twist', action='store_true', help='do not publish /imu/twist')
    p.add_argument('--compressed', choices=('png', 'jpeg'),
                   help='CompressedImage on the image topics + /compressed, not Image')
    p.add_argument('--jpeg-quality', type=int, default=95, help='--compressed jpeg (default 95)')
    p.add_argument('--raw-camera', action='store_true',
                   help='the raw images and camera_info of a calibrated rig (ros/rectify)')
    p.add_argument('--distortion-model', choices=raw_camera.DISTORTION_MODELS,
                   default='plumb_bob', help='--raw-camera: the lenses\' model (default plumb_bob)')
    return p.parse_args(argv)


def image_msg(path, frame_id, stamp, args, raw=None, side=0):
    """The mono8 Image of the file at `path`, or with args.compressed its CompressedImage (the
    format string as image_transport's compressed publisher writes it); with a RawStereoCamera
    `raw`, of the raw image of its camera `side` (0 left, 1 right)."""
    gray = cv2.imread(path, cv2.IMREAD_GRAYSCALE)
    if gray is None:
        raise ValueError('%s: cannot read the image' % path)
    if raw is not None:
        gray = raw.raw_image(side, gray)
    if args.compressed:
        params = [cv2.IMWRITE_JPEG_QUALITY, args.jpeg_quality] if args.compressed == 'jpeg' else []
        ok, data = cv2.imencode('.' + args.compressed, gray, params)
        if not ok:
            raise ValueError('%s: cannot encode the image as %s' % (path, args.compressed))
        msg = CompressedImage(format='mono8; %s compressed ' % args.compressed,
                              data=data.tobytes())
        msg.header.stamp = stamp
        msg.header.frame_id = frame_id
        return msg
    msg = Image()
    msg.header.stamp = stamp
    msg.header.frame_id = frame_id
    msg.height, msg.width = gray.shape
    msg.encoding = 'mono8'
    msg.step = gray.shape[1]
    msg.data = gray.tobytes()
    return msg


def image_topic(topic, args):
    if args.raw_camera:
        topic = topic.replace('/image_rect', '/image_raw')
    return topic + '/compressed' if args.compressed else topic


def messages(folder, args):
    """Yield (topic, msg, stamp) in time order; the first is /tf_static (when there are poses)."""
    n = len(folder.left) if args.max_frames <= 0 else min(args.max_frames, len(folder.left))
    times = folder.times[:n] + args.start_time
    first = cv2.imread(folder.left[0], cv2.IMREAD_GRAYSCALE)
    v = w = None
    groundtruth = None
    cam_T_imu = stereo_images.CAM_T_IMU
    if folder.world_T_cam is not None and not args.no_twist:
        cam_T_imu = stereo_images.travel_aligned_cam_T_imu(folder.world_T_cam[:n])
        world_T_imu = folder.world_T_cam[:n] @ cam_T_imu
        v, w = stereo_images.twist_from_poses(world_T_imu, times, args.twist_noise[0],
                                              args.twist_noise[1], args.gyro_offset, args.seed)
        groundtruth = world_T_imu
    image_size = (first.shape[1], first.shape[0])
    raw = None
    if args.raw_camera:
        raw = raw_camera.RawStereoCamera(folder.K, folder.b, image_size, args.distortion_model)
        # The tf gives the raw left camera; the tracker turns it to the rectified one.
        cam_T_imu = raw.raw_T_rectified(0) @ cam_T_imu
    calib = _Calibration(folder.K, folder.b, cam_T_imu, image_size, v, w)
    if v is not None:
        yield bag_writer.TOPIC_TF_STATIC, bag_writer.tf_static_msg(
            calib, bag_writer.to_ros_time(times[0])), bag_writer.to_ros_time(times[0])
    for k in range(n):
        stamp = bag_writer.to_ros_time(times[k])
        if v is not None:
            yield bag_writer.TOPIC_TWIST, bag_writer.twist_msg(calib, k, stamp), stamp
            yield bag_writer.TOPIC_GROUNDTRUTH, bag_writer.odometry_msg(
                np.linalg.inv(groundtruth[0]) @ groundtruth[k], stamp), stamp
        left_info, right_info = bag_writer.camera_info_msgs(calib, stamp)
        if raw is not None:
            raw.fill_camera_info(0, left_info)
            raw.fill_camera_info(1, right_info)
        yield bag_writer.TOPIC_LEFT_INFO, left_info, stamp
        yield bag_writer.TOPIC_RIGHT_INFO, right_info, stamp
        yield image_topic(TOPIC_LEFT_IMAGE, args), image_msg(
            folder.left[k], bag_writer.FRAME_CAMERA_LEFT, stamp, args, raw, 0), stamp
        yield image_topic(TOPIC_RIGHT_IMAGE, args), image_msg(
            folder.right[k], bag_writer.FRAME_CAMERA_RIGHT, stamp, args, raw, 1), stamp


def write_bag(folder, args):
    count = 0
    with rosbag.Bag(args.bag, 'w') as bag:
        for topic, msg, stamp in messages(folder, args):
            if topic == bag_writer.TOPIC_TF_STATIC:
                bag.write(topic, msg, stamp,
                          connection_header=bag_writer.tf_static_connection_header(msg, '/' + PROG))
            else:
                bag.write(topic, msg, stamp)
            count += topic == image_topic(TOPIC_LEFT_IMAGE, args)
    print('%s: %d stereo pairs -> %s' % (PROG, count, args.bag))


def play(folder, args):
    rospy.init_node('play_stereo_images', anonymous=True, disable_signals=True)
    publishers = {}
    clock = rospy.Publisher('/clock', Clock, queue_size=10)
    image_type = CompressedImage if args.compressed else Image
    types = dict(bag_writer.TOPIC_TYPES, **{image_topic(TOPIC_LEFT_IMAGE, args): image_type,
                                            image_topic(TOPIC_RIGHT_IMAGE, args): image_type})
    while True:
        wall_start = t_first = None
        for topic, msg, stamp in messages(folder, args):
            if topic not in publishers:
                publishers[topic] = rospy.Publisher(
                    topic, types[topic], queue_size=20, latch=topic == bag_writer.TOPIC_TF_STATIC)
                time.sleep(0.3)  # let subscribers connect
            if wall_start is None:
                wall_start, t_first = time.monotonic(), stamp.to_sec()
            delay = wall_start + (stamp.to_sec() - t_first) / args.rate - time.monotonic()
            if delay > 0:
                time.sleep(delay)
            clock.publish(Clock(clock=stamp))
            publishers[topic].publish(msg)
            if rospy.is_shutdown():
                return
        if not args.loop:
            return


def main(argv):
    args = parse_args(argv)
    try:
        folder = stereo_images.load_folder(args.folder, poses=args.poses)
    except (OSError, ValueError) as exc:
        print('%s: %s' % (PROG, exc), file=sys.stderr)
        return 2
    if folder.world_T_cam is None and not args.no_twist:
        print('%s: note: no poses (poses.txt, --poses), so no /imu/twist (the estimator needs '
              'one)' % PROG, file=sys.stderr)
    try:
        if args.bag:
            write_bag(folder, args)
        else:
            play(folder, args)
    except KeyboardInterrupt:
        return 130
    except (OSError, ValueError) as exc:
        print('%s: %s' % (PROG, exc), file=sys.stderr)
        return 1
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
