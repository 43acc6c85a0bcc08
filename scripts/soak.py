#!/usr/bin/python3
"""Reliability soak and outlier study of ekf_vislam on synthetic drives; prints the machine and
one table.

Soak: a one-hour drive (36,000 frames at 10 Hz, about 27 km) is simulated, converted to a bag and
run through vislam_offline, once whole and once cut after its first half. Reported: peak memory
(RSS of vislam_offline, measured by GNU time, see run_measured), the filter state bound
(peak_state_dimension and peak_active_landmarks of stats.json), the map size, the mean per-frame
time of the first and of the second half (stats.json has no per-frame series: the second half is
the whole run minus the half run), p50/p99, the counters that flag trouble and the ATE.
The one-hour drive reuses the ids of ended tracks after --reuse-ids-after frames (the course npz
layout is a dense (4, ids, frames) array: with a new id per track, one hour would need about
180,000 ids, 200 GB); the estimator sees a reappearing id as a new landmark.

Outliers: the default synthetic drive (simulate_dataset.py, 800 frames, its default 3 % gross
outliers) for each seed, with no outliers and with 5 % and 20 % extra (--outlier-rate 0.08 and
0.23); ATE (SE(3)-aligned RMSE) of each and the ratio to the default drive's (targets: <= 1.3x
and <= 2x).

    scripts/soak.sh [--frames 36000] [--seeds 1 2 3] [--out results/soak] [--skip-soak]
                    [--skip-outliers] [--keep-data]

Runtime on 2 (shared) cores: about 100 s (soak: simulation 11 s, bag 7 s, vislam_offline 32 s +
16 s; outlier study: 12 drives of 800 frames simulated, converted and run, about 35 s). Memory:
the simulation of the hour peaks at about 0.8 GB.
"""
import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import threading
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, '..', 'src'))
from ekf_vislam_tools import metrics, package, trajectory  # noqa: E402
from ekf_vislam_tools.report import fmt, machine_description, markdown_table  # noqa: E402

PY = '/usr/bin/python3'
DEFAULT_OUTLIER_RATE = 0.03  # simulator.DEFAULT_OPTIONS['outlier_rate']
EXTRA_OUTLIERS = (0.05, 0.20)
TARGET_RATIO = {0.05: 1.3, 0.20: 2.0}
#: Counters of stats.json that mean something went wrong during a clean drive.
TROUBLE_COUNTERS = ('divergence_recovery', 'covariance_repaired', 'update_non_finite',
                    'twist_gap', 'frame_capped', 'frame_stale', 'sequencer_late')


GNU_TIME = '/usr/bin/time'


def run_measured(cmd):
    """Runs cmd; returns (wall_s, peak_rss_mb of that process, stdout). Raises on failure.

    The peak RSS is not taken from os.wait4: Linux carries the peak RSS of the memory a child
    was forked (vforked) from over its exec, so wait4 would report this Python process's own peak
    when that is larger. GNU time forks the command from its own small process; without it the
    child's VmHWM is sampled from /proc every 20 ms (may miss a peak in its last 20 ms).
    """
    use_time = os.access(GNU_TIME, os.X_OK)
    rss_file = None
    if use_time:
        fd, rss_file = tempfile.mkstemp(prefix='soak_rss_')
        os.close(fd)
        cmd = [GNU_TIME, '-f', '%M', '-o', rss_file] + list(cmd)
    start = time.monotonic()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    chunks = {'out': [], 'err': []}
    sampled = [0]
    done = threading.Event()

    def drain(stream, key):  # a full pipe would block the child
        for block in iter(lambda: stream.read(65536), b''):
            chunks[key].append(block)

    def sample():
        while not done.wait(0.02):
            try:
                with open('/proc/%d/status' % proc.pid) as f:
                    for line in f:
                        if line.startswith('VmHWM:'):
                            sampled[0] = max(sampled[0], int(line.split()[1]))
            except OSError:
                return
    threads = [threading.Thread(target=drain, args=(proc.stdout, 'out')),
               threading.Thread(target=drain, args=(proc.stderr, 'err'))]
    if not use_time:
        threads.append(threading.Thread(target=sample))
    for t in threads:
        t.start()
    proc.wait()
    done.set()
    for t in threads:
        t.join()
    wall = time.monotonic() - start
    out, err = b''.join(chunks['out']).decode(), b''.join(chunks['err']).decode()
    peak_kb = sampled[0]
    if rss_file:
        with open(rss_file) as f:
            lines = f.read().split()
        os.remove(rss_file)
        peak_kb = int(lines[-1]) if lines and lines[-1].isdigit() else 0
    if proc.returncode != 0:
        raise RuntimeError('%s failed (exit %d):\n%s%s'
                           % (' '.join(cmd), proc.returncode, out, err))
    return wall, peak_kb / 1024.0, out


def offline_binary():
    path = package.vislam_offline_path()
    if path is None:
        sys.exit('soak: vislam_offline not built; run scripts/setup.sh first')
    return path


def log(text):
    print('soak: %s' % text, file=sys.stderr, flush=True)


def ate(trajectory_file, groundtruth_file):
    t, T = trajectory.read_tum(trajectory_file)
    tg, Tg = trajectory.read_tum(groundtruth_file)
    return metrics.evaluate_trajectory(t, T, tg, Tg)


def run_offline(binary, bag, out_dir, config):
    os.makedirs(out_dir, exist_ok=True)
    cmd = [binary, '--bag', bag, '--mode', 'slam', '--out', out_dir]
    if config:
        cmd += ['--config', config]
    wall, rss, _ = run_measured(cmd)
    with open(os.path.join(out_dir, 'stats.json')) as f:
        stats = json.load(f)
    return wall, rss, stats


def first_half_bag(bag_path, out_path, frames):
    """Copies the messages of the first `frames` feature frames of bag_path (raw, with their
    connection headers, so /tf_static stays latched) -> number of feature frames copied."""
    import rosbag
    copied = 0
    end = None
    tmp = out_path + '.tmp'
    with rosbag.Bag(bag_path) as src, rosbag.Bag(tmp, 'w') as dst:
        for topic, msg, t, header in src.read_messages(raw=True, return_connection_header=True):
            if end is not None and t > end:
                break
            if topic == '/stereo/features':
                copied += 1
                if copied == frames:
                    end = t  # keep what shares the last frame's stamp
            dst.write(topic, msg, t, raw=True, connection_header=header)
    os.replace(tmp, out_path)
    return copied


def simulate_child(prefix, seed, frames, reuse):
    """Runs in a child process (its memory and time measured apart): the long drive."""
    from ekf_vislam_tools import simulator
    result = simulator.simulate(int(seed), frames=int(frames), reuse_ids_after=int(reuse))
    simulator.write_outputs(result, prefix)
    print(simulator.summary(result))


# ---------------------------------------------------------------------------------------------
# Soak
# ---------------------------------------------------------------------------------------------
def soak_through_nodelet(prefix, out, rate, offline_trajectory):
    """Plays the whole drive through the nodelet (launch/play_dataset.launch, rosbag play with
    /clock at `rate` x real time, saved at shutdown) and compares it with vislam_offline."""
    folder = os.path.join(out, 'soak_nodelet')
    shutil.rmtree(folder, ignore_errors=True)
    env = dict(os.environ, ROS_HOME=tempfile.mkdtemp(prefix='ekf_vislam_soak_ros_'))
    log('the whole drive through the nodelet at %gx ...' % rate)
    start = time.monotonic()
    subprocess.run(['roslaunch', 'ekf_vislam', 'play_dataset.launch', 'bag:=' + prefix + '.bag',
                    'rate:=%g' % rate, 'rviz:=false', 'output_dir:=' + folder],
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env, check=False)
    wall = time.monotonic() - start
    shutil.rmtree(env['ROS_HOME'], ignore_errors=True)
    with open(os.path.join(folder, 'stats.json')) as f:
        stats = json.load(f)
    _, T = trajectory.read_tum(os.path.join(folder, 'trajectory.tum'))
    _, T_offline = trajectory.read_tum(offline_trajectory)
    n = min(len(T), len(T_offline))
    difference = float(np.abs(T[:n, :3, 3] - T_offline[:n, :3, 3]).max()) if n else float('nan')
    log('  nodelet: %d frames, %d twists, %d late, %.1f s wall, peak RSS %.0f MB, max difference '
        'to vislam_offline %.3g m over %d poses (offline: %d)' % (
            stats['frames'], stats['twists'], stats.get('sequencer_late', -1), wall,
            stats.get('peak_rss_mb', float('nan')), difference, len(T), len(T_offline)))
    return {'case': 'soak through the nodelet at %gx' % rate, 'frames': stats['frames'],
            'data_h': stats['data_s'] / 3600.0, 'ate_m': None, 'rpe_percent': None,
            'peak_rss_mb': stats.get('peak_rss_mb'), 'process_wall_s': wall,
            'estimator_wall_s': stats['wall_s'],
            'peak_state_dimension': stats['peak_state_dimension'],
            'peak_active_landmarks': stats['peak_active_landmarks'], 'map_size': stats['landmarks'],
            'frame_ms_mean': stats['frame_ms']['mean'], 'frame_ms_p50': stats['frame_ms']['p50'],
            'frame_ms_p99': stats['frame_ms']['p99'], 'frame_ms_max': stats['frame_ms']['max'],
            'difference_to_offline_m': difference,
            'trouble': {k: stats['counters'].get(k, stats.get(k, 0)) for k in TROUBLE_COUNTERS}}


def soak(args, binary, out):
    data = os.path.join(out, 'data')
    os.makedirs(data, exist_ok=True)
    prefix = os.path.join(data, 'soak')
    log('simulating %d frames ...' % args.frames)
    sim_wall, sim_rss, summary = run_measured(
        [PY, os.path.abspath(__file__), '--simulate-child', prefix, str(args.seed),
         str(args.frames), str(args.reuse_ids_after)])
    log('  %s (%.1f s, peak %.0f MB)' % (summary.strip(), sim_wall, sim_rss))
    log('converting to a bag ...')
    bag_wall, bag_rss, _ = run_measured([PY, os.path.join(HERE, 'dataset_to_bag.py'),
                                         prefix + '.npz', prefix + '.bag'])
    half_frames = args.frames // 2
    start = time.monotonic()
    copied = first_half_bag(prefix + '.bag', prefix + '_half.bag', half_frames)
    half_wall = time.monotonic() - start
    log('  bag %.1f s (peak %.0f MB), first-half bag %.1f s' % (bag_wall, bag_rss, half_wall))
    if copied != half_frames:
        raise RuntimeError('first-half bag has %d frames, expected %d' % (copied, half_frames))

    log('vislam_offline on the first half ...')
    half = run_offline(binary, prefix + '_half.bag', os.path.join(out, 'soak_half'), args.config)
    log('vislam_offline on the whole drive ...')
    full = run_offline(binary, prefix + '.bag', os.path.join(out, 'soak_full'), args.config)
    m_full = ate(os.path.join(out, 'soak_full', 'trajectory.tum'), prefix + '_groundtruth.tum')
    m_half = ate(os.path.join(out, 'soak_half', 'trajectory.tum'), prefix + '_groundtruth.tum')

    rows = []
    for name, (wall, rss, stats), m in (('soak first half', half, m_half),
                                        ('soak whole hour', full, m_full)):
        rows.append({
            'case': name, 'frames': stats['frames'], 'data_h': stats['data_s'] / 3600.0,
            'path_km': m['path_length_m'] / 1000.0, 'ate_m': m['ate_rmse_m'],
            'rpe_percent': m['rpe_percent'], 'peak_rss_mb': rss, 'process_wall_s': wall,
            'estimator_wall_s': stats['wall_s'],
            'peak_state_dimension': stats['peak_state_dimension'],
            'peak_active_landmarks': stats['peak_active_landmarks'],
            'map_size': stats['landmarks'], 'frame_ms_mean': stats['frame_ms']['mean'],
            'frame_ms_p50': stats['frame_ms']['p50'], 'frame_ms_p99': stats['frame_ms']['p99'],
            'frame_ms_max': stats['frame_ms']['max'],
            'trouble': {k: stats['counters'].get(k, stats.get(k, 0)) for k in TROUBLE_COUNTERS}})
    n_half, n_full = half[2]['frames'], full[2]['frames']
    second_mean = ((full[2]['frame_ms']['mean'] * n_full - half[2]['frame_ms']['mean'] * n_half)
                   / (n_full - n_half))
    rows.append(dict(rows[1], case='soak second half (whole - first)', frames=n_full - n_half,
                     frame_ms_mean=second_mean, frame_ms_p50=None, frame_ms_p99=None,
                     frame_ms_max=None, ate_m=None, rpe_percent=None, peak_rss_mb=None,
                     process_wall_s=None, estimator_wall_s=None, map_size=None,
                     data_h=rows[1]['data_h'] - rows[0]['data_h'],
                     path_km=rows[1]['path_km'] - rows[0]['path_km'],
                     peak_state_dimension=None, peak_active_landmarks=None))
    if args.nodelet_rate > 0:
        rows.append(soak_through_nodelet(prefix, out, args.nodelet_rate,
                                         os.path.join(out, 'soak_full', 'trajectory.tum')))
    info = {'simulate_s': sim_wall, 'simulate_peak_mb': sim_rss, 'bag_s': bag_wall,
            'bag_peak_mb': bag_rss, 'half_bag_s': half_wall, 'simulation': summary.strip(),
            'bag_mb': os.path.getsize(prefix + '.bag') / 1e6,
            'npz_mb': os.path.getsize(prefix + '.npz') / 1e6}
    if not args.keep_data:
        shutil.rmtree(data)
    return rows, info


# ---------------------------------------------------------------------------------------------
# Outlier study
# ---------------------------------------------------------------------------------------------
def outlier_study(args, binary, out):
    data = os.path.join(out, 'data')
    os.makedirs(data, exist_ok=True)
    rates = [0.0, DEFAULT_OUTLIER_RATE] + [DEFAULT_OUTLIER_RATE + e for e in EXTRA_OUTLIERS]
    rows = []
    for seed in args.seeds:
        base = None
        for rate in rates:
            name = 'sim%d_outliers%02d' % (seed, round(100 * rate))
            prefix = os.path.join(data, name)
            log('outliers: seed %d, outlier rate %.2f ...' % (seed, rate))
            run_measured([PY, os.path.join(HERE, 'simulate_dataset.py'), '--seed', str(seed),
                          '--frames', str(args.outlier_frames), '--outlier-rate', repr(rate),
                          '--out', prefix])
            run_measured([PY, os.path.join(HERE, 'dataset_to_bag.py'), prefix + '.npz',
                          prefix + '.bag'])
            wall, rss, stats = run_offline(binary, prefix + '.bag', os.path.join(out, name),
                                           args.config)
            m = ate(os.path.join(out, name, 'trajectory.tum'), prefix + '_groundtruth.tum')
            row = {'case': 'seed %d, outliers %.2f%s' % (
                       seed, rate, ' (default)' if rate == DEFAULT_OUTLIER_RATE else
                       (' (+%.2f)' % (rate - DEFAULT_OUTLIER_RATE) if rate > DEFAULT_OUTLIER_RATE
                        else ' (none)')),
                   'seed': seed, 'outlier_rate': rate, 'frames': stats['frames'],
                   'ate_m': m['ate_rmse_m'], 'rpe_percent': m['rpe_percent'],
                   'peak_rss_mb': rss, 'estimator_wall_s': stats['wall_s'],
                   'peak_state_dimension': stats['peak_state_dimension'],
                   'peak_active_landmarks': stats['peak_active_landmarks'],
                   'map_size': stats['landmarks'], 'frame_ms_mean': stats['frame_ms']['mean'],
                   'frame_ms_p50': stats['frame_ms']['p50'],
                   'frame_ms_p99': stats['frame_ms']['p99'],
                   'gated': stats['counters']['observation_gated'],
                   'trouble': {k: stats['counters'].get(k, stats.get(k, 0))
                               for k in TROUBLE_COUNTERS}}
            if rate == DEFAULT_OUTLIER_RATE:
                base = row['ate_m']
            rows.append(row)
        for row in rows:
            if row['seed'] == seed:
                row['ratio'] = row['ate_m'] / base
    if not args.keep_data:
        shutil.rmtree(data)
    return rows


# ---------------------------------------------------------------------------------------------
# Report
# ---------------------------------------------------------------------------------------------
def table(rows):
    header = ['case', 'frames', 'data h', 'ATE m', 'ATE ratio', 'peak RSS MB', 'peak state dim',
              'peak active lm', 'map size', 'ms/frame mean', 'p50 ms', 'p99 ms', 'trouble counters']
    cells = []
    for r in rows:
        trouble = ', '.join('%s %d' % (k, v) for k, v in r.get('trouble', {}).items() if v)
        cells.append([
            r['case'], '%d' % r['frames'], fmt(r.get('data_h'), '.2f'), fmt(r.get('ate_m'), '.3f'),
            fmt(r.get('ratio'), '.2f'), fmt(r.get('peak_rss_mb'), '.0f'),
            fmt(r.get('peak_state_dimension'), 'd'), fmt(r.get('peak_active_landmarks'), 'd'),
            fmt(r.get('map_size'), 'd'), fmt(r.get('frame_ms_mean'), '.3f'),
            fmt(r.get('frame_ms_p50'), '.3f'), fmt(r.get('frame_ms_p99'), '.3f'), trouble or 'none'])
    return markdown_table(header, cells)


def summary_lines(soak_rows, soak_info, outlier_rows):
    lines = []
    if soak_rows:
        half, full, second = soak_rows[:3]
        lines.append('soak: %s' % soak_info['simulation'])
        for row in soak_rows[3:]:
            lines.append('soak: %s: %d frames, peak RSS %.0f MB, peak state dimension %d, p99 %.3f '
                         'ms, max difference to vislam_offline %.3g m' % (
                             row['case'], row['frames'], row['peak_rss_mb'],
                             row['peak_state_dimension'], row['frame_ms_p99'],
                             row['difference_to_offline_m']))
        lines.append('soak: inputs: simulation %.1f s (peak %.0f MB, npz %.0f MB), bag %.1f s '
                     '(peak %.0f MB, %.0f MB)' % (
                         soak_info['simulate_s'], soak_info['simulate_peak_mb'],
                         soak_info['npz_mb'], soak_info['bag_s'], soak_info['bag_peak_mb'],
                         soak_info['bag_mb']))
        lines.append('soak: vislam_offline peak RSS %.0f MB after half an hour, %.0f MB after the '
                     'hour (+%.0f MB for %d more map landmarks)' % (
                         half['peak_rss_mb'], full['peak_rss_mb'],
                         full['peak_rss_mb'] - half['peak_rss_mb'],
                         full['map_size'] - half['map_size']))
        lines.append('soak: filter state bound: peak state dimension %d (first half %d), peak '
                     'active landmarks %d (first half %d): %s' % (
                         full['peak_state_dimension'], half['peak_state_dimension'],
                         full['peak_active_landmarks'], half['peak_active_landmarks'],
                         'bounded' if full['peak_state_dimension'] == half['peak_state_dimension']
                         else 'GREW in the second half'))
        ratio = second['frame_ms_mean'] / half['frame_ms_mean']
        lines.append('soak: mean per-frame time %.3f ms (first half) -> %.3f ms (second half): '
                     'x%.2f; whole hour p50 %.3f ms, p99 %.3f ms, max %.1f ms; estimator wall '
                     '%.1f s for %.2f h of data' % (
                         half['frame_ms_mean'], second['frame_ms_mean'], ratio,
                         full['frame_ms_p50'], full['frame_ms_p99'], full['frame_ms_max'],
                         full['estimator_wall_s'], full['data_h']))
        lines.append('soak: ATE %.2f m over %.1f km (RPE %.2f %%)' % (
            full['ate_m'], full['path_km'], full['rpe_percent']))
    if outlier_rows:
        seeds = sorted({r['seed'] for r in outlier_rows})
        for extra in EXTRA_OUTLIERS:
            rate = DEFAULT_OUTLIER_RATE + extra
            ratios = [r['ratio'] for r in outlier_rows if abs(r['outlier_rate'] - rate) < 1e-9]
            worst = max(ratios)
            lines.append('outliers +%.2f (rate %.2f): ATE ratio to the default drive mean %.2f, '
                         'worst %.2f over %d seeds (target <= %.1f): %s' % (
                             extra, rate, sum(ratios) / len(ratios), worst, len(seeds),
                             TARGET_RATIO[extra], 'met' if worst <= TARGET_RATIO[extra]
                             else 'NOT MET'))
        none = {r['seed']: r['ate_m'] for r in outlier_rows if r['outlier_rate'] == 0.0}
        lines.append('outliers none: ATE ratio to the default drive mean %.2f' % (
            sum(r['ratio'] for r in outlier_rows if r['outlier_rate'] == 0.0) / len(none)))
        for extra in EXTRA_OUTLIERS:
            rate = DEFAULT_OUTLIER_RATE + extra
            ratios = [r['ate_m'] / none[r['seed']] for r in outlier_rows
                      if abs(r['outlier_rate'] - rate) < 1e-9]
            lines.append('outliers %.2f against no outliers at all: ATE ratio mean %.2f, worst '
                         '%.2f' % (rate, sum(ratios) / len(ratios), max(ratios)))
    return lines


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--frames', type=int, default=36000,
                        help='frames of the soak drive (default %(default)s = 1 h at 10 Hz)')
    parser.add_argument('--seed', type=int, default=1, help='seed of the soak drive')
    parser.add_argument('--reuse-ids-after', type=int, default=10,
                        help='soak drive: reuse the id of a track unseen for this many frames '
                             '(default %(default)s)')
    parser.add_argument('--seeds', type=int, nargs='+', default=[1, 2, 3],
                        help='seeds of the outlier study (default 1 2 3)')
    parser.add_argument('--outlier-frames', type=int, default=800,
                        help='frames of each outlier-study drive (default %(default)s, the '
                             'simulator default)')
    parser.add_argument('--config', default=None, help='options YAML (default: the shipped one)')
    parser.add_argument('--out', default=os.path.join(HERE, '..', 'results', 'soak'))
    parser.add_argument('--nodelet-rate', type=float, default=0.0,
                        help='also play the whole drive through the nodelet at this rate '
                             '(x real time; 20 takes about 3 min); 0 = skip (default)')
    parser.add_argument('--skip-soak', action='store_true')
    parser.add_argument('--skip-outliers', action='store_true')
    parser.add_argument('--keep-data', action='store_true',
                        help='keep the simulated datasets and bags (about 250 MB)')
    parser.add_argument('--simulate-child', nargs=4, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.simulate_child:
        simulate_child(*args.simulate_child)
        return
    if args.frames < 2:
        parser.error('--frames must be at least 2')
    out = os.path.abspath(args.out)
    os.makedirs(out, exist_ok=True)
    binary = offline_binary()
    machine = machine_description()
    start = time.monotonic()
    soak_rows, soak_info, outlier_rows = [], {}, []
    if not args.skip_soak:
        soak_rows, soak_info = soak(args, binary, out)
    if not args.skip_outliers:
        outlier_rows = outlier_study(args, binary, out)
    text = machine + '\n\n' + table(soak_rows + outlier_rows)
    text += '\n\n' + '\n'.join(summary_lines(soak_rows, soak_info, outlier_rows))
    text += '\n\nsoak.py total run time %.0f s' % (time.monotonic() - start)
    print(text)
    with open(os.path.join(out, 'soak.md'), 'w') as f:
        f.write(text + '\n')
    with open(os.path.join(out, 'soak.json'), 'w') as f:
        json.dump({'soak': soak_rows, 'soak_inputs': soak_info, 'outliers': outlier_rows}, f,
                  indent=1)
    log('wrote %s/soak.md and soak.json' % out)


if __name__ == '__main__':
    main()
