#!/usr/bin/python3
"""Summary of a demo run: a table of the three modes (accuracy and the reported covariance's
consistency when ground truth was evaluated, speed, map size) and, without ground truth, a
top-down plot of the trajectories and the map. NEES: the mean normalized estimation error
squared of the position (3 when the covariance is right) and of the pose (6).

    demo_summary.py RUN_DIR   (RUN_DIR holds slam/, mapping/, deadreckoning/ and maybe eval/)
"""
import json
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, '..', 'src'))
from ekf_vislam_tools import trajectory  # noqa: E402

MODES = ('slam', 'mapping', 'deadreckoning')


def main():
    if len(sys.argv) != 2:
        sys.exit('usage: demo_summary.py RUN_DIR')
    run_dir = sys.argv[1]
    metrics = {}
    eval_json = os.path.join(run_dir, 'eval', 'metrics.json')
    if os.path.exists(eval_json):
        with open(eval_json) as f:
            metrics = json.load(f)['estimates']
    lines = ['| mode | ATE m | RPE % | rotation RMSE deg | final error m | NEES position (3) | '
             'NEES pose (6) | landmarks | frames | wall s | x real time | p99 ms/frame |',
             '|' + '---|' * 12]
    for mode in MODES:
        with open(os.path.join(run_dir, mode, 'stats.json')) as f:
            s = json.load(f)
        m = metrics.get(mode, {})

        def num(key, spec='.2f'):
            v = m.get(key)
            if isinstance(v, dict):  # a NEES block: its mean
                v = v.get('mean')
            return '-' if v is None else format(v, spec)
        lines.append('| %s | %s | %s | %s | %s | %s | %s | %d | %d | %.3f | %.0f | %.2f |' % (
            mode, num('ate_rmse_m'), num('rpe_percent'), num('rotation_rmse_deg'),
            num('final_position_error_m'), num('nees_position'), num('nees_pose'),
            s['landmarks'], s['frames'], s['wall_s'], s['realtime_factor'],
            s['frame_ms']['p99']))
    table = '\n'.join(lines)
    with open(os.path.join(run_dir, 'summary.md'), 'w') as f:
        f.write(table + '\n')
    print(table)
    if not metrics:
        plot_without_groundtruth(run_dir)


def plot_without_groundtruth(run_dir):
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(8, 7))
    landmarks = np.genfromtxt(os.path.join(run_dir, 'slam', 'landmarks.csv'), delimiter=',',
                              names=True)
    if landmarks.size:
        ax.scatter(landmarks['x'], landmarks['y'], s=1, c='green', label='landmarks (SLAM)')
    for mode, color in zip(MODES, ('red', 'tab:blue', 'tab:gray')):
        _, T = trajectory.read_tum(os.path.join(run_dir, mode, 'trajectory.tum'))
        ax.plot(T[:, 0, 3], T[:, 1, 3], color=color, label=mode, lw=1.5)
    ax.set_aspect('equal', adjustable='datalim')
    ax.set_xlabel('x (m, world = first IMU pose)')
    ax.set_ylabel('y (m)')
    ax.set_title('%s: trajectories and map (no ground truth)' % os.path.basename(run_dir))
    ax.legend(loc='best')
    path = os.path.join(run_dir, 'trajectory_topdown.png')
    fig.savefig(path, dpi=120, bbox_inches='tight')
    print('wrote %s' % path)


if __name__ == '__main__':
    main()
