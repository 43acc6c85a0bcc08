#!/usr/bin/python3
"""Accuracy and speed of ekf_vislam on the course datasets and on synthetic drives.

Converts each dataset of the data folder (every NAME.npz, its ground truth
groundtruth/NAME_imu_gt.tum) to a bag (cached), runs vislam_offline in the three modes, evaluates
against ground truth and prints one table (also written as benchmark.md / benchmark.json).
Speed: wall time and per-frame times from stats.json; peak memory (resident set) as the process
itself reports it in stats.json (getrusage): a fork's rusage would include the parent's pages.

    scripts/benchmark.sh [--data DIR] [--seeds 1 2 3] [--out results/benchmark]
"""
import argparse
import json
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, '..', 'src'))
from ekf_vislam_tools import metrics, package, trajectory  # noqa: E402
from ekf_vislam_tools.report import fmt, machine_description, markdown_table  # noqa: E402

MODES = ('slam', 'mapping', 'deadreckoning')
PY = '/usr/bin/python3'


def run(cmd):
    """Runs cmd; returns its wall time in s. Raises on failure with its output."""
    start = time.monotonic()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        raise RuntimeError('%s failed:\n%s%s' % (' '.join(cmd), proc.stdout, proc.stderr))
    return time.monotonic() - start


def offline_binary():
    path = package.vislam_offline_path()
    if path is None:
        sys.exit('benchmark: vislam_offline not built; run scripts/setup.sh first')
    return path


def evaluate_case(name, bag, groundtruth, out_dir, binary, config):
    rows = []
    for mode in MODES:
        mode_dir = os.path.join(out_dir, name, mode)
        os.makedirs(mode_dir, exist_ok=True)
        cmd = [binary, '--bag', bag, '--mode', mode, '--out', mode_dir]
        if config:
            cmd += ['--config', config]
        wall = run(cmd)
        with open(os.path.join(mode_dir, 'stats.json')) as f:
            stats = json.load(f)
        row = {'dataset': name, 'mode': mode, 'frames': stats['frames'],
               'landmarks': stats['landmarks'], 'process_wall_s': round(wall, 3),
               'estimator_wall_s': stats['wall_s'], 'data_s': stats['data_s'],
               'frame_ms_p50': stats['frame_ms']['p50'], 'frame_ms_p99': stats['frame_ms']['p99'],
               'frame_ms_max': stats['frame_ms']['max'], 'peak_rss_mb': stats.get('peak_rss_mb'),
               'observations_used': stats['observations_used'],
               'observations_rejected': stats['observations_rejected']}
        if groundtruth:
            t, T = trajectory.read_tum(os.path.join(mode_dir, 'trajectory.tum'))
            tg, Tg = trajectory.read_tum(groundtruth)
            m = metrics.evaluate_trajectory(t, T, tg, Tg)
            row.update(ate_m=m['ate_rmse_m'], rpe_percent=m['rpe_percent'],
                       rot_rmse_deg=m['rotation_rmse_deg'], final_m=m['final_position_error_m'])
            row.update(consistency(mode_dir, t, T, tg, Tg))
        rows.append(row)
    return rows


def consistency(run_dir, t, T, t_gt, T_gt):
    """Mean position and pose NEES of a run against ground truth ({} without covariances)."""
    path = os.path.join(run_dir, 'trajectory_covariance.txt')
    if not os.path.exists(path):
        return {}
    t_cov, P = metrics.read_trajectory_covariance(path)
    c = metrics.consistency(t, T, t_cov, P, t_gt, T_gt)
    return dict(nees_position=c['nees_position']['mean'], nees_pose=c['nees_pose']['mean'],
                nees_position_inside_95=c['nees_position']['inside_95'])


def table(rows):
    header = ['dataset', 'mode', 'ATE m', 'RPE %', 'rot deg', 'NEES pos', 'NEES pose', 'frames',
              'landmarks', 'wall s', 'x real time', 'p50 ms', 'p99 ms', 'peak MB']
    cells = []
    for r in rows:
        rt = r['data_s'] / r['estimator_wall_s'] if r['estimator_wall_s'] > 0 else None
        cells.append([
            r['dataset'], r['mode'], fmt(r.get('ate_m'), '.2f'), fmt(r.get('rpe_percent'), '.2f'),
            fmt(r.get('rot_rmse_deg'), '.2f'), fmt(r.get('nees_position'), '.2f'),
            fmt(r.get('nees_pose'), '.2f'), '%d' % r['frames'], '%d' % r['landmarks'],
            fmt(r['estimator_wall_s'], '.3f'), fmt(rt, '.0f'), fmt(r['frame_ms_p50'], '.2f'),
            fmt(r['frame_ms_p99'], '.2f'), fmt(r['peak_rss_mb'], '.0f')])
    return markdown_table(header, cells)


def find_datasets(data_dir):
    """(name, npz, ground truth or None) of each NAME.npz in data_dir, the ground truth
    groundtruth/NAME_imu_gt.tum when it is there; those with ground truth first, each group by
    name."""
    names = sorted(f[:-4] for f in os.listdir(data_dir) if f.endswith('.npz')) \
        if os.path.isdir(data_dir) else []
    found = []
    for name in names:
        gt = os.path.join(data_dir, 'groundtruth', name + '_imu_gt.tum')
        npz = os.path.join(data_dir, name + '.npz')
        found.append((name, npz, gt if os.path.exists(gt) else None))
    return sorted(found, key=lambda dataset: dataset[2] is None)


def dataset_cases(data_dir, bags):
    """(name, bag, ground truth or None) of every dataset in data_dir; a bag is converted again
    when its npz is newer."""
    cases = []
    for name, npz, gt in find_datasets(data_dir):
        bag = os.path.join(bags, name + '.bag')
        if not os.path.exists(bag) or os.path.getmtime(bag) < os.path.getmtime(npz):
            run([PY, os.path.join(HERE, 'dataset_to_bag.py'), npz, bag])
        cases.append((name, bag, gt))
    return cases


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    default_data = os.path.join(HERE, '..', '..', 'shared', 'data')
    parser.add_argument('--data', default=os.environ.get('EKF_VISLAM_DATA', default_data),
                        help='folder of datasets: every NAME.npz in it, with the ground truth '
                        'groundtruth/NAME_imu_gt.tum where there is one')
    parser.add_argument('--seeds', type=int, nargs='*', default=[1, 2, 3, 4, 5])
    parser.add_argument('--config', default=None, help='options YAML (default: the shipped one)')
    parser.add_argument('--out', default=os.path.join(HERE, '..', 'results', 'benchmark'))
    args = parser.parse_args()
    out = os.path.abspath(args.out)
    bags = os.path.join(out, 'bags')
    os.makedirs(bags, exist_ok=True)
    binary = offline_binary()
    machine = machine_description()
    cases = []
    for seed in args.seeds:
        prefix = os.path.join(bags, 'sim%d' % seed)
        if not os.path.exists(prefix + '.bag'):
            run([PY, os.path.join(HERE, 'simulate_dataset.py'), '--seed', str(seed),
                 '--out', prefix])
            run([PY, os.path.join(HERE, 'dataset_to_bag.py'), prefix + '.npz', prefix + '.bag'])
        cases.append(('sim%d' % seed, prefix + '.bag', prefix + '_groundtruth.tum'))
    cases += dataset_cases(args.data, bags)
    rows = []
    for name, bag, gt in cases:
        print('benchmark: %s ...' % name, file=sys.stderr, flush=True)
        rows += evaluate_case(name, bag, gt, out, binary, args.config)
    text = machine + '\n\n' + table(rows)
    print(text)
    slam_sims = [r['ate_m'] for r in rows if r['dataset'].startswith('sim') and r['mode'] == 'slam']
    if slam_sims:
        summary = 'synthetic drives, SLAM ATE: mean %.3f m, max %.3f m over %d seeds' % (
            sum(slam_sims) / len(slam_sims), max(slam_sims), len(slam_sims))
        print(summary)
        text += '\n\n' + summary
    with open(os.path.join(out, 'benchmark.md'), 'w') as f:
        f.write(text + '\n')
    with open(os.path.join(out, 'benchmark.json'), 'w') as f:
        json.dump(rows, f, indent=1)
    print('benchmark: wrote %s/benchmark.md and benchmark.json' % out, file=sys.stderr)


if __name__ == '__main__':
    main()
