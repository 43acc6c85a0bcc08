#!/usr/bin/python3
"""Compares two runs of ekf_vislam (folders with trajectory.tum and stats.json).

Prints the largest position difference between the two trajectories (poses matched by stamp; a
stamp present in only one of them is a difference), every counter of stats.json that differs,
and, for information, the largest landmark position difference of landmarks.csv and the other
numbers of stats.json that differ. Timing and memory fields are ignored.

    scripts/compare_runs.py DIR_A DIR_B [--tolerance M]

Exit status 0 when the position difference is at most the tolerance (default 1e-9 m) and every
counter is equal, 1 otherwise, 2 when a file is missing or unreadable. Uses: checking that a
refactor leaves the output unchanged, comparing a live (nodelet) run with vislam_offline.
"""
import argparse
import csv
import json
import math
import os
import sys

# Fields of stats.json that measure the machine, not the estimator.
TIMING_FIELDS = frozenset(['wall_s', 'realtime_factor', 'frame_ms', 'peak_rss_mb'])
# Stamps are written with 9 decimals: two stamps closer than this are the same frame.
STAMP_MATCH_S = 1e-6


def read_positions(path):
    """{stamp: (x, y, z)} of a TUM trajectory file."""
    positions = {}
    with open(path) as f:
        for line in f:
            fields = line.split()
            if not fields or fields[0].startswith('#'):
                continue
            if len(fields) != 8:
                raise ValueError('%s: expected 8 numbers per line, got %r' % (path, line))
            positions[round(float(fields[0]) / STAMP_MATCH_S)] = tuple(map(float, fields[1:4]))
    return positions


def trajectory_difference(a, b):
    """(max position difference in m, poses compared, stamps present in only one)."""
    common = a.keys() & b.keys()
    worst = 0.0
    for stamp in common:
        worst = max(worst, math.dist(a[stamp], b[stamp]))
    missing = len(a.keys() ^ b.keys())
    if missing:
        worst = math.inf
    return worst, len(common), missing


def read_landmarks(path):
    """[(id, x, y, z)] in file order of a landmarks.csv (ids repeat after a restart)."""
    with open(path) as f:
        return [(row['id'], float(row['x']), float(row['y']), float(row['z']))
                for row in csv.DictReader(f)]


def landmark_difference(a, b):
    """Max position difference of the landmarks in file order; inf when ids or counts differ."""
    if len(a) != len(b):
        return math.inf
    worst = 0.0
    for la, lb in zip(a, b):
        if la[0] != lb[0]:
            return math.inf
        worst = max(worst, math.dist(la[1:], lb[1:]))
    return worst


def flatten(stats, prefix=''):
    """{'counters/obs_gated': 3, 'frames': 100, ...} without the timing fields."""
    flat = {}
    for key, value in stats.items():
        if not prefix and key in TIMING_FIELDS:
            continue
        name = prefix + key
        if isinstance(value, dict):
            flat.update(flatten(value, name + '/'))
        else:
            flat[name] = value
    return flat


def is_counter(value):
    return isinstance(value, int) and not isinstance(value, bool) or isinstance(value, str)


def compare_stats(a, b):
    """(differing counters, differing other numbers): lists of (name, value_a, value_b). A
    counter is an integer (or text) field; a field present in one file only differs."""
    fa, fb = flatten(a), flatten(b)
    counters, others = [], []
    for name in sorted(fa.keys() | fb.keys()):
        va, vb = fa.get(name), fb.get(name)
        if va == vb:
            continue
        if va is None or vb is None or is_counter(va) or is_counter(vb):
            counters.append((name, va, vb))
        else:
            others.append((name, va, vb))
    return counters, others


def compare(dir_a, dir_b, tolerance, out=sys.stdout):
    """Prints the comparison; returns the exit status (0 equal, 1 different)."""
    traj_a = read_positions(os.path.join(dir_a, 'trajectory.tum'))
    traj_b = read_positions(os.path.join(dir_b, 'trajectory.tum'))
    worst, compared, missing = trajectory_difference(traj_a, traj_b)
    print('trajectory: %d poses matched, %d stamps in one run only, max position difference '
          '%.3g m (tolerance %.3g m)' % (compared, missing, worst, tolerance), file=out)
    landmarks_a = os.path.join(dir_a, 'landmarks.csv')
    landmarks_b = os.path.join(dir_b, 'landmarks.csv')
    if os.path.exists(landmarks_a) and os.path.exists(landmarks_b):
        la, lb = read_landmarks(landmarks_a), read_landmarks(landmarks_b)
        print('landmarks: %d vs %d, max position difference %.3g m (information)' %
              (len(la), len(lb), landmark_difference(la, lb)), file=out)
    with open(os.path.join(dir_a, 'stats.json')) as f:
        stats_a = json.load(f)
    with open(os.path.join(dir_b, 'stats.json')) as f:
        stats_b = json.load(f)
    counters, others = compare_stats(stats_a, stats_b)
    if counters:
        for name, va, vb in counters:
            print('counter %s differs: %s vs %s' % (name, va, vb), file=out)
    else:
        print('counters: all equal', file=out)
    for name, va, vb in others:
        print('number %s differs: %s vs %s (information)' % (name, va, vb), file=out)
    same = worst <= tolerance and not counters
    print('result: %s' % ('SAME' if same else 'DIFFERENT'), file=out)
    return 0 if same else 1


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('dir_a')
    parser.add_argument('dir_b')
    parser.add_argument('--tolerance', type=float, default=1e-9,
                        help='largest position difference accepted, m (default 1e-9)')
    args = parser.parse_args(argv)
    try:
        return compare(args.dir_a, args.dir_b, args.tolerance)
    except (OSError, ValueError, KeyError) as e:
        print('compare_runs: %s' % e, file=sys.stderr)
        return 2


if __name__ == '__main__':
    sys.exit(main())
