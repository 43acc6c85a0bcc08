"""Messages read back from a bag: stereo feature messages as rows that compare exactly (live
against offline), and an odometry topic (a ground truth) as poses."""
import numpy as np
import rosbag

from ekf_vislam_tools import se3

TOPIC_FEATURES = '/stereo/features'


def feature_rows(msg):
    """A StereoFeatureArray as (stamp ns, frame_id, [(id, u_left, v_left, u_right, v_right)])."""
    return (msg.header.stamp.to_nsec(), msg.header.frame_id,
            [(f.id, f.u_left, f.v_left, f.u_right, f.v_right) for f in msg.features])


def read_feature_rows(bag_path, topic=TOPIC_FEATURES):
    """feature_rows of every message on `topic`, in bag order."""
    with rosbag.Bag(bag_path) as bag:
        return [feature_rows(msg) for _, msg, _ in bag.read_messages(topics=[topic])]


def read_odometry_poses(bag_path, topic):
    """-> (t[N], T[N,4,4]): the header stamps and poses of the nav_msgs/Odometry on `topic`
    (N = 0 when the bag has none)."""
    stamps, poses = [], []
    with rosbag.Bag(bag_path) as bag:
        for _, msg, _ in bag.read_messages(topics=[topic]):
            p, q = msg.pose.pose.position, msg.pose.pose.orientation
            T = np.eye(4)
            T[:3, :3] = se3.quaternion_to_rotation([q.x, q.y, q.z, q.w])
            T[:3, 3] = [p.x, p.y, p.z]
            stamps.append(msg.header.stamp.to_sec())
            poses.append(T)
    return np.array(stamps), np.array(poses).reshape(-1, 4, 4)
