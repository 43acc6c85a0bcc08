"""ROS messages of a `Dataset` (the estimator's inputs and optional ground truth) and bag writing.

`iter_messages` yields the messages in bag order; `write_bag` writes them to a bag through a
temporary file, and the live player of dataset_to_bag.py publishes the same stream.

Topics and frames (message time = header stamp = dataset time stamp; the camera's messages plus
``camera_delay``, which merges them into the other messages in stamp order):

- ``/tf_static`` (tf2_msgs/TFMessage, latched, once at the first stamp): imu -> camera_left
  (imu_T_cam = inverse(cam_T_imu)) and camera_left -> camera_right (+b along x);
- per frame, in this order: ``/imu/twist`` (geometry_msgs/TwistStamped, frame ``imu``),
  ``/stereo/left/camera_info`` and ``/stereo/right/camera_info`` (sensor_msgs/CameraInfo,
  rectified), ``/stereo/features`` (ekf_vislam/StereoFeatureArray, frame ``camera_left``, the
  observed features of the frame, id = column index of the features array; in column order, or
  oldest track first when the columns are shared);
- with twist type ``imu_odometry``, instead of ``/imu/twist``: ``/imu/data`` (sensor_msgs/Imu,
  frame ``imu``: the angular velocity) and ``/wheel/odometry`` (nav_msgs/Odometry, child
  ``base_link``: the linear velocity of that frame, placed at IMU_T_BASE; /tf_static then
  holds base_link -> imu too), the two inputs of the twist combiner;
- when the dataset has an accelerometer (``specific_force``): its sample k is the
  ``linear_acceleration`` of an ``/imu/data`` message at stamp t_k (m/s^2, frame ``imu``,
  covariance all zero: unknown). With ``imu_odometry`` that is the gyro's message; with every other
  twist type an ``/imu/data`` of its own follows ``/imu/twist``, with no orientation and no angular
  velocity (their covariances' [0] = -1). One accelerometer sample per twist sample: a slower
  camera or wheel odometry (features_every, wheel_every) drops frames and wheel messages, never
  /imu/data. Without ``specific_force`` the bags are as before (imu_odometry's Imu:
  linear_acceleration_covariance[0] = -1, no data);
- with ground truth: ``/groundtruth/odometry`` (nav_msgs/Odometry, frame ``world``, child
  ``imu``), re-anchored so that the first pose is the identity, interleaved in time order.
"""
import heapq
import math
import os

import numpy as np
import rosbag
import rospy
from geometry_msgs.msg import TransformStamped, TwistStamped, TwistWithCovarianceStamped
from nav_msgs.msg import Odometry
from sensor_msgs.msg import CameraInfo, Imu
from tf2_msgs.msg import TFMessage

from ekf_vislam.msg import StereoFeature, StereoFeatureArray
from ekf_vislam_tools import se3, trajectory

TOPIC_TF_STATIC = '/tf_static'
TOPIC_TWIST = '/imu/twist'
TOPIC_LEFT_INFO = '/stereo/left/camera_info'
TOPIC_RIGHT_INFO = '/stereo/right/camera_info'
TOPIC_FEATURES = '/stereo/features'
TOPIC_GROUNDTRUTH = '/groundtruth/odometry'
TOPIC_IMU = '/imu/data'
TOPIC_WHEEL_ODOMETRY = '/wheel/odometry'

FRAME_WORLD = 'world'
FRAME_IMU = 'imu'
FRAME_CAMERA_LEFT = 'camera_left'
FRAME_CAMERA_RIGHT = 'camera_right'
FRAME_BASE = 'base_link'
FRAME_ODOM = 'odom'

#: imu_T_base of the wheel odometry's frame in ``imu_odometry`` bags: 1.2 m behind the IMU,
#: 0.1 m to its left, 0.4 m below, turned 3 degrees in yaw (a lever arm the combiner must undo).
IMU_T_BASE = np.eye(4)
IMU_T_BASE[:3, :3] = se3.so3_exp(np.array([0.0, 0.0, math.radians(3.0)]))
IMU_T_BASE[:3, 3] = [-1.2, 0.1, -0.4]

#: The twist type that writes a gyro and a wheel odometry instead of /imu/twist.
IMU_ODOMETRY = 'imu_odometry'

DEFAULT_CALLERID = '/dataset_to_bag'

#: Message class of every topic `iter_messages` yields.
TOPIC_TYPES = {
    TOPIC_TF_STATIC: TFMessage,
    TOPIC_TWIST: TwistStamped,
    TOPIC_LEFT_INFO: CameraInfo,
    TOPIC_RIGHT_INFO: CameraInfo,
    TOPIC_FEATURES: StereoFeatureArray,
    TOPIC_GROUNDTRUTH: Odometry,
}


def to_ros_time(seconds):
    """float seconds -> rospy.Time, rounded to the nearest nanosecond."""
    secs = int(math.floor(seconds))
    nsecs = int(round((seconds - secs) * 1e9))
    if nsecs >= 1000000000:
        secs, nsecs = secs + 1, nsecs - 1000000000
    return rospy.Time(secs, nsecs)


# ---------------------------------------------------------------------------------------------
# Message builders
# ---------------------------------------------------------------------------------------------
def _set_pose(pose, T):
    """Fill a geometry_msgs Pose (position/orientation) or Transform (translation/rotation)."""
    q = se3.rotation_to_quaternion(T[:3, :3])
    position = pose.position if hasattr(pose, 'position') else pose.translation
    orientation = pose.orientation if hasattr(pose, 'orientation') else pose.rotation
    position.x, position.y, position.z = (float(x) for x in T[:3, 3])
    orientation.x, orientation.y, orientation.z, orientation.w = (float(x) for x in q)


def tf_static_msg(dataset, stamp, with_base=False):
    """/tf_static: imu -> camera_left (imu_T_cam) and camera_left -> camera_right (+b along x);
    with_base: also base_link -> imu (the inverse of IMU_T_BASE), as a robot's tree has it."""
    imu_T_cam = se3.inverse(dataset.cam_T_imu)
    left_T_right = np.eye(4)
    left_T_right[0, 3] = dataset.b
    msg = TFMessage()
    transforms = [(FRAME_IMU, FRAME_CAMERA_LEFT, imu_T_cam),
                  (FRAME_CAMERA_LEFT, FRAME_CAMERA_RIGHT, left_T_right)]
    if with_base:  # the robot's tree: base_link -> imu -> camera_left
        transforms.insert(0, (FRAME_BASE, FRAME_IMU, se3.inverse(IMU_T_BASE)))
    for parent, child, parent_T_child in transforms:
        tf = TransformStamped()
        tf.header.stamp = stamp
        tf.header.frame_id = parent
        tf.child_frame_id = child
        _set_pose(tf.transform, parent_T_child)
        msg.transforms.append(tf)
    return msg


def tf_static_connection_header(msg, callerid=DEFAULT_CALLERID):
    """Connection header that marks /tf_static as latched in a bag (as rosbag record does)."""
    return {'callerid': callerid, 'topic': TOPIC_TF_STATIC, 'type': 'tf2_msgs/TFMessage',
            'md5sum': msg._md5sum, 'message_definition': msg._full_text, 'latching': '1'}


#: ros/twist_type -> message class of /imu/twist.
TWIST_TYPES = {'twist_stamped': TwistStamped, 'twist_with_covariance': TwistWithCovarianceStamped,
               'odometry': Odometry}


def twist_msg(dataset, k, stamp, twist_type='twist_stamped', covariance=None):
    """The IMU twist of frame k as TwistStamped, TwistWithCovarianceStamped or Odometry (child
    frame = the IMU frame; pose left at identity). covariance: 6x6 per-sample covariance of
    [v; w] for the two types that carry one (default all zero: none given)."""
    msg = TWIST_TYPES[twist_type]()
    msg.header.stamp = stamp
    msg.header.frame_id = FRAME_IMU
    twist = msg.twist
    if twist_type == 'odometry':
        msg.header.frame_id = FRAME_WORLD
        msg.child_frame_id = FRAME_IMU
        msg.pose.pose.orientation.w = 1.0
    if twist_type != 'twist_stamped':
        if covariance is not None:
            twist.covariance = [float(x) for x in np.asarray(covariance).ravel()]
        twist = twist.twist
    twist.linear.x, twist.linear.y, twist.linear.z = (float(x) for x in dataset.v[:, k])
    twist.angular.x, twist.angular.y, twist.angular.z = (float(x) for x in dataset.w[:, k])
    return msg


def _set_linear_acceleration(imu, dataset, k):
    """The accelerometer sample k (specific force, m/s^2, IMU frame) into an Imu message, with an
    all-zero covariance (ROS: unknown); without an accelerometer, covariance[0] = -1 (no data).

    Sample k is the mean specific force over (t_k-1, t_k], the interval that ends at the stamp of
    the message (t_k): the dataset has one accelerometer sample per twist sample, so every Imu
    stamp is a sample's own stamp, also when the wheel odometry or the camera is slower
    (wheel_every, features_every only thin those out)."""
    if dataset.specific_force is None:
        imu.linear_acceleration_covariance[0] = -1.0
        return
    acceleration = imu.linear_acceleration
    acceleration.x, acceleration.y, acceleration.z = (
        float(x) for x in dataset.specific_force[:, k])


def accelerometer_msg(dataset, k, stamp):
    """Imu of frame k holding only the accelerometer (dataset.specific_force[:, k], m/s^2, frame
    ``imu``, covariance zero: unknown): no orientation and no angular velocity (covariance[0] =
    -1 each, angular velocity zero). For the twist types other than imu_odometry."""
    imu = Imu()
    imu.header.stamp = stamp
    imu.header.frame_id = FRAME_IMU
    imu.orientation_covariance[0] = -1.0
    imu.angular_velocity_covariance[0] = -1.0
    _set_linear_acceleration(imu, dataset, k)
    return imu


def imu_odometry_msgs(dataset, k, stamp, covariance=None):
    """(Imu, Odometry) of frame k: the gyro (angular velocity in ``imu``; with an accelerometer
    also its sample k, see `_set_linear_acceleration`) and the wheel odometry (the velocity of
    ``base_link``, at IMU_T_BASE, in its own axes: v_base = R^T (v_imu - p x w_imu)), whose
    combination is the dataset's twist. covariance: 6x6 of [v; w] per sample (None: the Imu's
    marked unknown, the odometry's all zero)."""
    v_imu, w_imu = dataset.v[:, k], dataset.w[:, k]
    R, p = IMU_T_BASE[:3, :3], IMU_T_BASE[:3, 3]
    imu = Imu()
    imu.header.stamp = stamp
    imu.header.frame_id = FRAME_IMU
    imu.orientation_covariance[0] = -1.0
    _set_linear_acceleration(imu, dataset, k)
    imu.angular_velocity.x, imu.angular_velocity.y, imu.angular_velocity.z = (
        float(x) for x in w_imu)
    odometry = Odometry()
    odometry.header.stamp = stamp
    odometry.header.frame_id = FRAME_ODOM
    odometry.child_frame_id = FRAME_BASE
    odometry.pose.pose.orientation.w = 1.0
    linear = odometry.twist.twist.linear
    linear.x, linear.y, linear.z = (float(x) for x in R.T @ (v_imu - np.cross(p, w_imu)))
    angular = odometry.twist.twist.angular
    angular.x, angular.y, angular.z = (float(x) for x in R.T @ w_imu)
    if covariance is None:
        imu.angular_velocity_covariance[0] = -1.0
    else:
        covariance = np.asarray(covariance, dtype=float)
        imu.angular_velocity_covariance = [float(x) for x in covariance[3:, 3:].ravel()]
        odometry_covariance = np.zeros((6, 6))
        odometry_covariance[:3, :3] = R.T @ covariance[:3, :3] @ R
        odometry.twist.covariance = [float(x) for x in odometry_covariance.ravel()]
    return imu, odometry


def camera_info_msgs(dataset, stamp):
    """(left, right) rectified CameraInfo: R = I, no distortion, right P[0,3] = -fx b."""
    K = dataset.K
    width, height = dataset.image_size if dataset.image_size is not None else (0, 0)
    msgs = []
    for frame_id, tx in ((FRAME_CAMERA_LEFT, 0.0), (FRAME_CAMERA_RIGHT, -K[0, 0] * dataset.b)):
        msg = CameraInfo()
        msg.header.stamp = stamp
        msg.header.frame_id = frame_id
        msg.width, msg.height = width, height
        msg.distortion_model = 'plumb_bob'
        msg.D = [0.0] * 5
        msg.K = [float(x) for x in K.reshape(-1)]
        msg.R = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
        msg.P = [float(K[0, 0]), 0.0, float(K[0, 2]), float(tx),
                 0.0, float(K[1, 1]), float(K[1, 2]), 0.0,
                 0.0, 0.0, 1.0, 0.0]
        msgs.append(msg)
    return tuple(msgs)


def features_msg(dataset, k, stamp, ids):
    """StereoFeatureArray of frame k holding the features `ids` (column indices, observed)."""
    msg = StereoFeatureArray()
    msg.header.stamp = stamp
    msg.header.frame_id = FRAME_CAMERA_LEFT
    z = dataset.features[:, ids, k]
    msg.features = [StereoFeature(id=int(j), u_left=float(z[0, i]), v_left=float(z[1, i]),
                                  u_right=float(z[2, i]), v_right=float(z[3, i]))
                    for i, j in enumerate(ids)]
    return msg


def odometry_msg(world_T_imu, stamp):
    msg = Odometry()
    msg.header.stamp = stamp
    msg.header.frame_id = FRAME_WORLD
    msg.child_frame_id = FRAME_IMU
    _set_pose(msg.pose.pose, world_T_imu)
    return msg


# ---------------------------------------------------------------------------------------------
# Ground truth
# ---------------------------------------------------------------------------------------------
def load_groundtruth(path, dataset):
    """Ground truth for a dataset -> (t[N], world_T_imu[N,4,4]) with the first pose = identity.

    A TUM file holds world_T_imu with its own times; a KITTI poses file (world_T_cam0) is turned
    into world_T_imu with the dataset's frame times and cam_T_imu. Re-anchoring makes the world
    frame the IMU frame at the first ground-truth pose, as in the estimator. Problems raise
    `trajectory.TrajectoryError`.
    """
    try:
        t, world_T_imu = trajectory.read_groundtruth(path, dataset.t, dataset.cam_T_imu)
    except (OSError, UnicodeDecodeError) as exc:
        raise trajectory.TrajectoryError('%s: cannot read ground truth (%s)'
                                         % (path, getattr(exc, 'strerror', None) or exc))
    if len(t) == 0:
        raise trajectory.TrajectoryError('%s: no poses' % path)
    steps = np.diff(t)
    if np.any(steps <= 0):
        raise trajectory.TrajectoryError('%s: time stamps not strictly increasing at pose %d'
                                         % (path, int(np.argmax(steps <= 0)) + 1))
    if t[0] < 0:
        raise trajectory.TrajectoryError('%s: negative time stamp' % path)
    first_T_world = se3.inverse(world_T_imu[0])
    return t, np.einsum('ij,njk->nik', first_T_world, world_T_imu)


# ---------------------------------------------------------------------------------------------
# Message stream and bag
# ---------------------------------------------------------------------------------------------
def features_by_age(observed):
    """Per frame, the observed columns oldest track first: by the frame their run of consecutive
    frames started, then by column. For a dataset whose columns hold several tracks, one after
    the other (`Dataset.columns_shared`): the estimator starts waiting tracks in the message's
    order when its state is full (landmarks/max_active), and a tracker lists its tracks oldest
    first; with a column per id the tracker's npz gives that order by its columns."""
    start = np.full(observed.shape[0], -1)
    previous = np.zeros(observed.shape[0], dtype=bool)
    for k in range(observed.shape[1]):
        now = observed[:, k]
        start[now & ~previous] = k
        previous = now
        ids = np.flatnonzero(now)
        yield ids[np.lexsort((ids, start[ids]))]


def _twist_messages(dataset, twist_type, twist_covariance, wheel_every=1):
    for k in range(dataset.num_frames):
        stamp = to_ros_time(dataset.t[k])
        if twist_type == IMU_ODOMETRY:
            imu, odometry = imu_odometry_msgs(dataset, k, stamp, twist_covariance)
            yield stamp, 0, TOPIC_IMU, imu
            if k % wheel_every == 0:
                yield stamp, 0, TOPIC_WHEEL_ODOMETRY, odometry
        else:
            yield stamp, 0, TOPIC_TWIST, twist_msg(dataset, k, stamp, twist_type,
                                                   twist_covariance)
            if dataset.specific_force is not None:
                yield stamp, 0, TOPIC_IMU, accelerometer_msg(dataset, k, stamp)


def _camera_messages(dataset, features_every=1, camera_delay=0.0):
    observed = dataset.observed()
    by_age = features_by_age(observed) if dataset.columns_shared else None
    for k in range(dataset.num_frames):
        ids = next(by_age) if by_age else np.flatnonzero(observed[:, k])
        if k % features_every != 0:
            continue
        stamp = to_ros_time(dataset.t[k] + camera_delay)
        left, right = camera_info_msgs(dataset, stamp)
        yield stamp, 1, TOPIC_LEFT_INFO, left
        yield stamp, 1, TOPIC_RIGHT_INFO, right
        yield stamp, 1, TOPIC_FEATURES, features_msg(dataset, k, stamp, ids)


def _groundtruth_messages(groundtruth):
    t, world_T_imu = groundtruth
    for tk, T in zip(t, world_T_imu):
        stamp = to_ros_time(tk)
        yield stamp, 2, TOPIC_GROUNDTRUTH, odometry_msg(T, stamp)


def first_stamp(dataset, camera_delay=0.0):
    """Stamp of the first message of iter_messages (/tf_static): the first twist's, or the first
    camera message's when it comes earlier (camera_delay < 0)."""
    return to_ros_time(dataset.t[0] + min(0.0, camera_delay))


def iter_messages(dataset, groundtruth=None, twist_type='twist_stamped', twist_covariance=None,
                  wheel_every=1, features_every=1, camera_delay=0.0):
    """Yield (topic, msg, stamp) in bag order: /tf_static, then per frame twist (of twist_type;
    IMU_ODOMETRY: gyro and wheel odometry; with an accelerometer and another type, the twist and
    then the accelerometer's /imu/data), left and right camera_info, features; ground truth
    (t, world_T_imu) interleaved by time (after the frame's messages at equal stamps).
    wheel_every (IMU_ODOMETRY) and features_every keep one wheel sample, one feature frame every
    that many twist samples: slower sensors than the dataset's rate. camera_delay (s) stamps the
    camera's messages that much after the twist of their frame (a camera whose stamps lag; the
    estimator's extrinsic/camera_time_offset is its negative)."""
    first = first_stamp(dataset, camera_delay)
    yield TOPIC_TF_STATIC, tf_static_msg(dataset, first, twist_type == IMU_ODOMETRY), first
    streams = [_twist_messages(dataset, twist_type, twist_covariance, wheel_every),
               _camera_messages(dataset, features_every, camera_delay)]
    if groundtruth is not None:
        streams.append(_groundtruth_messages(groundtruth))
    for stamp, _, topic, msg in heapq.merge(*streams, key=lambda item: (item[0], item[1])):
        yield topic, msg, stamp


class BagSummary(object):
    """What was written: counts per kind and the bag path."""

    def __init__(self, path):
        self.path = path
        self.frames = 0
        self.feature_messages = 0
        self.observations = 0
        self.groundtruth_poses = 0

    def __str__(self):
        text = ('%d frames, %d feature messages, %d observations'
                % (self.frames, self.feature_messages, self.observations))
        if self.groundtruth_poses:
            text += ', %d ground-truth poses' % self.groundtruth_poses
        return text + ' -> %s' % self.path


def write_bag(dataset, out_path, groundtruth=None, progress=None, callerid=DEFAULT_CALLERID,
              twist_type='twist_stamped', twist_covariance=None, wheel_every=1, features_every=1,
              camera_delay=0.0):
    """Write the dataset (and optional ground truth) to `out_path` -> BagSummary.

    Writes `<out_path>.tmp-<pid>` and renames it on success; on any error (or KeyboardInterrupt)
    the temporary file is removed and the exception propagates, so no half bag is left.
    progress(frames_done, frames_total) is called after each frame when given.
    """
    tmp_path = '%s.tmp-%d' % (out_path, os.getpid())
    summary = BagSummary(out_path)
    try:
        with rosbag.Bag(tmp_path, 'w') as bag:
            for topic, msg, stamp in iter_messages(dataset, groundtruth, twist_type,
                                                   twist_covariance, wheel_every, features_every,
                                                   camera_delay):
                if topic == TOPIC_TF_STATIC:
                    bag.write(topic, msg, stamp,
                              connection_header=tf_static_connection_header(msg, callerid))
                    continue
                bag.write(topic, msg, stamp)
                if topic == TOPIC_FEATURES:
                    summary.feature_messages += 1
                    summary.observations += len(msg.features)
                    summary.frames += 1
                    if progress is not None:
                        progress(summary.frames, -(-dataset.num_frames // features_every))
                elif topic == TOPIC_GROUNDTRUTH:
                    summary.groundtruth_poses += 1
        os.replace(tmp_path, out_path)
    except BaseException:
        try:
            os.remove(tmp_path)
        except OSError:
            pass
        raise
    return summary
