"""Fault injection into an estimator input bag (dataset_to_bag.py output): one instance of each
fault class the estimator handles, and optionally gross outliers and periodic empty feature
messages (a tracker that lost an image). Used by scripts/inject_faults.py and the faults rostest."""
import copy

import numpy as np
import rosbag
import rospy
from ekf_vislam.msg import StereoFeature, StereoFeatureArray


def inject_faults(clean_bag, faulty_bag, outlier_fraction=0.0, empty_every=0, seed=1):
    """Copies clean_bag with one instance of each fault class (and a swapped pair of twists),
    plus, when asked, gross outliers (this fraction of the observations moved to random image
    positions, ids kept) and an empty feature message every `empty_every` frames. Returns the
    expected minimum count of each counter in stats.json."""
    with rosbag.Bag(clean_bag) as bag:
        messages = list(bag.read_messages(return_connection_header=True))
    frames = [m for m in messages if m.topic == '/stereo/features']
    twists = [m for m in messages if m.topic == '/imu/twist']
    t0 = twists[0].message.header.stamp

    def twist_like(index, dt, v=None):
        msg = twists[index].message.__class__()
        msg.header = twists[index].message.header.__class__()
        msg.header.frame_id = 'imu'
        msg.header.stamp = twists[index].message.header.stamp + rospy.Duration(dt)
        msg.twist = copy.deepcopy(twists[index].message.twist)
        if v is not None:
            msg.twist.linear.x, msg.twist.linear.y, msg.twist.linear.z = v
        return msg

    extra = []  # (bag time, topic, message)
    nan = float('nan')
    # Twists: NaN, implausible, duplicate stamp, time going backwards.
    extra.append((twists[50].timestamp + rospy.Duration(0.03), '/imu/twist', twist_like(50, 0.03, (nan, 0, 0))))
    extra.append((twists[60].timestamp + rospy.Duration(0.03), '/imu/twist', twist_like(60, 0.03, (500.0, 0, 0))))
    extra.append((twists[70].timestamp, '/imu/twist', twist_like(70, 0.0)))
    extra.append((twists[80].timestamp + rospy.Duration(0.01), '/imu/twist', twist_like(80, -0.5)))
    # Features before any twist.
    early = StereoFeatureArray()
    early.header.stamp = t0 - rospy.Duration(1.0)
    early.header.frame_id = 'camera_left'
    early.features = frames[0].message.features[:5]
    extra.append((twists[0].timestamp - rospy.Duration(1.0), '/stereo/features', early))
    # A huge message: 10,000 features with new ids at random places.
    rng = np.random.default_rng(seed)
    huge = StereoFeatureArray()
    huge.header.stamp = frames[130].message.header.stamp + rospy.Duration(0.05)
    huge.header.frame_id = 'camera_left'
    for i in range(10000):
        u, v = rng.uniform(0, 1240), rng.uniform(0, 375)
        huge.features.append(StereoFeature(id=10_000_000 + i, u_left=u, v_left=v,
                                           u_right=u - rng.uniform(1, 60), v_right=v))
    extra.append((frames[130].timestamp + rospy.Duration(0.05), '/stereo/features', huge))

    def modify(index, msg):
        f = msg.features
        if index == 90:
            f[0].u_left = nan                      # NaN coordinate
        elif index == 100:
            for k in range(3):
                f[k].u_right = f[k].u_left + 5.0   # negative disparity
        elif index == 110:
            f.append(copy.deepcopy(f[0]))          # duplicate id
        elif index == 120:
            msg.features = []                      # empty message
        elif index == 140:
            for k in range(2):
                f[k].v_right = f[k].v_left + 50.0  # rows disagree
        elif empty_every > 0 and index > 0 and index % empty_every == 0:
            msg.features = []                      # a tracker that lost an image
        if outlier_fraction > 0.0:
            for feature in msg.features:
                if rng.uniform() < outlier_fraction:  # a wrong match: anywhere in the image
                    u, v = rng.uniform(0, 1240), rng.uniform(0, 375)
                    feature.u_left, feature.v_left = u, v
                    feature.u_right, feature.v_right = u - rng.uniform(1, 60), v
        return msg

    frame_index = {id(m): k for k, m in enumerate(frames)}
    # A swapped pair: twists 200 and 201 arrive in reverse order (the later one first).
    bag_time = {id(m): m.timestamp for m in messages}
    swapped = len(twists) > 202
    if swapped:
        a, b = id(twists[200]), id(twists[201])
        bag_time[a], bag_time[b] = bag_time[b], bag_time[a] - rospy.Duration(1e-6)
    out = []
    for m in messages:
        msg = m.message
        if m.topic == '/stereo/features':
            msg = modify(frame_index[id(m)], msg)
        out.append((bag_time[id(m)], m.topic, msg, m.connection_header))
    out += [(t, topic, msg, None) for t, topic, msg in extra]
    out.sort(key=lambda x: x[0])
    with rosbag.Bag(faulty_bag, 'w') as bag:
        for t, topic, msg, header in out:
            bag.write(topic, msg, t, connection_header=header)
    return {'twist_non_finite': 1, 'twist_implausible': 1, 'twist_time_not_increasing': 2,
            'frame_before_twist': 1, 'frame_capped': 1, 'observation_non_finite': 1,
            'observation_disparity': 3, 'observation_duplicate_id': 1, 'frame_empty': 1,
            'observation_row_mismatch': 2}
