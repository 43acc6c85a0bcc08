#!/usr/bin/python3
"""What each twist costs the estimator: a twist rate N times the bag's.

    benchmark_twist_rate.py [--bag IN.bag] [--split N] [--repeat R] [--config FILE]

Writes a copy of the bag whose /imu/twist interval [t_k-1, t_k] is covered by N twists of the
same value (stamps spread evenly, the last at t_k), as a gyro N times faster would give, then
runs vislam_offline on both bags, alternated, R times each, and prints the wall seconds, their
medians and the estimator time per extra twist. Without --bag a 300-frame drive is simulated
(simulate_dataset.py --seed 3). The twist noise is taken from the config's densities
(noise/estimate_twist_noise false, unless --config says otherwise): identical consecutive
samples would read as noise-free to the online estimate.
"""
import argparse
import copy
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time

import rosbag
import rospy

HERE = os.path.dirname(os.path.abspath(__file__))
PY = '/usr/bin/python3'
TWIST = '/imu/twist'


def run(cmd):
    result = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            universal_newlines=True)
    if result.returncode != 0:
        sys.exit('benchmark_twist_rate: %s failed:\n%s' % (' '.join(cmd), result.stdout))
    return result.stdout


def split_bag(source, target, n):
    """Each twist after the first becomes n twists over its interval; -> twists written."""
    written = 0
    with rosbag.Bag(source) as src, rosbag.Bag(target, 'w') as dst:
        previous = None
        for topic, msg, t, header in src.read_messages(return_connection_header=True):
            if topic != TWIST:
                dst.write(topic, msg, t, connection_header=header)
                continue
            stamp = msg.header.stamp.to_sec()
            parts = [msg] if previous is None else []
            for j in range(1, n + 1 if previous is not None else 1):
                part = copy.deepcopy(msg)
                if j < n:
                    part.header.stamp = rospy.Time.from_sec(previous + (stamp - previous) * j / n)
                parts.append(part)
            for part in parts:
                dst.write(topic, part, part.header.stamp)
            written += len(parts)
            previous = stamp
    return written


def offline_wall_s(binary, bag, config, out):
    """-> (twists the estimator took, wall seconds of the vislam_offline process)."""
    start = time.monotonic()
    text = run([binary, '--bag', bag, '--config', config, '--out', out])
    wall = time.monotonic() - start
    return int(re.search(r'(\d+) twists', text).group(1)), wall


def main(argv):
    parser = argparse.ArgumentParser(prog='benchmark_twist_rate.py',
                                     description=__doc__.split('\n')[0])
    parser.add_argument('--bag', help='estimator bag (default: a simulated 300-frame drive)')
    parser.add_argument('--split', type=int, default=10, help='twists per interval (default 10)')
    parser.add_argument('--repeat', type=int, default=3, help='runs per bag (default 3)')
    parser.add_argument('--config', help='estimator options (default: config/default.yaml with '
                        'noise/estimate_twist_noise false)')
    args = parser.parse_args(argv)
    tmp = tempfile.mkdtemp(prefix='ekf_vislam_twist_rate_')
    binary = os.path.join(os.environ.get('EKF_VISLAM_WS', os.path.join(HERE, '..', 'build')),
                          'devel', 'lib', 'ekf_vislam', 'vislam_offline')
    bag = args.bag
    if bag is None:
        prefix = os.path.join(tmp, 'sim')
        run([PY, os.path.join(HERE, 'simulate_dataset.py'), '--seed', '3', '--frames', '300',
             '--out', prefix])
        bag = prefix + '.bag'
        run([PY, os.path.join(HERE, 'dataset_to_bag.py'), prefix + '.npz', bag])
    config = args.config
    if config is None:
        config = os.path.join(tmp, 'config.yaml')
        text = open(os.path.join(HERE, '..', 'config', 'default.yaml')).read()
        open(config, 'w').write(re.sub(r'(\n  estimate_twist_noise:) true', r'\1 false', text))
    split = os.path.join(tmp, 'split.bag')
    split_bag(bag, split, args.split)
    walls = {'bag': [], 'split': []}
    twists = {}
    for _ in range(args.repeat):
        for name, path in (('bag', bag), ('split', split)):
            twists[name], wall = offline_wall_s(binary, path, config, os.path.join(tmp, name))
            walls[name].append(wall)
    for name in ('bag', 'split'):
        print('%-5s %6d twists: wall s %s, median %.2f' % (
            name, twists[name], ' '.join('%.2f' % w for w in walls[name]),
            statistics.median(walls[name])))
    extra = twists['split'] - twists['bag']
    per_twist = (statistics.median(walls['split']) - statistics.median(walls['bag'])) / extra
    print('per extra twist: %.3f ms (median against median; %d extra twists)'
          % (1e3 * per_twist, extra))
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
