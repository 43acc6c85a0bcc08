#!/usr/bin/python3
"""The landmark study: SLAM accuracy and consistency against the fraction of landmark ids kept.

    landmark_study.py [--data DIR] [--sequences NAME ...] [--out DIR] [--fractions F ...]
                      [--seeds N ...] [--config YAML] [--accel-noise SIGMA] [--jobs 2]

For every dataset of the data folder with ground truth (NAME.npz and groundtruth/NAME_imu_gt.tum;
on the course data 0027 and 0034), both twists (the file's own, "course", and one from
the ground truth with 0.05 m/s / 0.005 rad/s white noise and a 0.001 rad/s gyro offset,
"accurate"), every fraction and seed: scripts/make_variant.py, dataset_to_bag.py, vislam_offline
in slam mode, and dead reckoning per twist and seed. Writes OUT/landmark_study.md (the regime
table: SLAM ATE mean and max over seeds, dead-reckoning ATE, their ratio, mean position NEES),
OUT/landmark_study.png and OUT/landmark_study.json, and prints the table and the wall time.
With --accel-noise every variant also carries an accelerometer made from the ground truth
(make_variant.py --accel-noise: that white noise per sample, no bias), which SLAM uses.
"""
import argparse
import concurrent.futures
import json
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, '..', 'src'))
sys.path.insert(0, HERE)
from benchmark import consistency, find_datasets, offline_binary, run  # noqa: E402
from ekf_vislam_tools import metrics, trajectory, variants  # noqa: E402
from ekf_vislam_tools.report import fmt, markdown_table  # noqa: E402

PY = '/usr/bin/python3'
TWISTS = ('course', 'accurate')


def run_folder(out, job):
    """OUT/runs/<sequence>_<twist>_f<percent>_s<seed>: one variant, both modes."""
    sequence, twist, fraction, seed = job[:4]
    return os.path.join(out, 'runs', '%s_%s_f%03d_s%d' % (sequence, twist, round(fraction * 100),
                                                          seed))


def run_variant(folder, data, sequence, mode, binary, config, **variant_args):
    """One variant of a sequence (`variants.make_variant` with variant_args), its bag in folder
    (made once, shared by the modes), vislam_offline in that mode and the evaluation against the
    ground truth -> dict of ATE, RPE, observations per frame, path length and NEES (position,
    pose)."""
    os.makedirs(folder, exist_ok=True)
    gt = os.path.join(data, 'groundtruth', sequence + '_imu_gt.tum')
    npz, bag = os.path.join(folder, 'data.npz'), os.path.join(folder, 'data.bag')
    if not os.path.exists(bag):
        with np.load(os.path.join(data, sequence + '.npz')) as archive:
            arrays = {key: archive[key] for key in archive.files}
        variant, _ = variants.make_variant(arrays, gt, **variant_args)
        np.savez(npz, **variant)
        run([PY, os.path.join(HERE, 'dataset_to_bag.py'), npz, bag])
        os.remove(npz)  # the bag has everything (about 70 MB each)
    run_dir = os.path.join(folder, mode)
    cmd = [binary, '--bag', bag, '--mode', mode, '--out', run_dir]
    run(cmd + (['--config', config] if config else []))
    t, T = trajectory.read_tum(os.path.join(run_dir, 'trajectory.tum'))
    t_gt, T_gt = trajectory.read_tum(gt)
    m = metrics.evaluate_trajectory(t, T, t_gt, T_gt)
    with open(os.path.join(run_dir, 'stats.json')) as f:
        observations_per_frame = json.load(f).get('observations_per_frame')
    result = dict(ate_m=m['ate_rmse_m'], rpe_percent=m['rpe_percent'],
                  path_length_m=m['path_length_m'], observations_per_frame=observations_per_frame,
                  run_dir=run_dir)
    result.update(consistency(run_dir, t, T, t_gt, T_gt))
    return result


def one_run(job, data, out, binary, config, accel_noise=None):
    """job = (sequence, twist, fraction, seed, mode) -> result dict."""
    sequence, twist, fraction, seed, mode = job
    result = dict(sequence=sequence, twist=twist, fraction=fraction, seed=seed, mode=mode)
    result.update(run_variant(run_folder(out, job), data, sequence, mode, binary, config,
                              twist=twist, keep_fraction=fraction, seed=seed,
                              accel_noise=accel_noise))
    return result


def run_jobs(run_one, jobs, workers):
    """run_one over jobs (tuples whose last item is the mode) on `workers` threads: the SLAM runs
    first, since each makes its variant's bag, then the others, which share it."""
    with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, workers)) as pool:
        results = list(pool.map(run_one, [j for j in jobs if j[-1] == 'slam']))
        results += list(pool.map(run_one, [j for j in jobs if j[-1] != 'slam']))
    return results


def remove_bags(results):
    """Deletes the variants' bags (about 70 MB each for a whole drive) once every mode ran."""
    for folder in {os.path.dirname(r['run_dir']) for r in results}:
        bag = os.path.join(folder, 'data.bag')
        if os.path.exists(bag):
            os.remove(bag)


def write_study(out, name, text, rows, results, wall, extra=()):
    """OUT/NAME.md (the table) and OUT/NAME.json (rows, runs, wall time); prints the table and
    what was written (extra: other suffixes written beside them, e.g. png)."""
    os.makedirs(out, exist_ok=True)
    with open(os.path.join(out, name + '.md'), 'w') as f:
        f.write(text + '\n')
    with open(os.path.join(out, name + '.json'), 'w') as f:
        json.dump(dict(rows=rows, runs=results, wall_s=wall), f, indent=1)
    print(text)
    print('%s: %d runs in %.0f s; wrote %s/%s.{%s}' % (name.replace('_', ' '), len(results), wall,
                                                      out, name, ','.join(('md',) + tuple(extra)
                                                                          + ('json',))))


def summarize(results, sequences, fractions):
    rows, cells = [], []
    for sequence in sequences:
        for twist in TWISTS:
            dr = [r['ate_m'] for r in results if r['sequence'] == sequence and
                  r['twist'] == twist and r['mode'] == 'deadreckoning']
            for fraction in fractions:
                slam = [r for r in results if r['sequence'] == sequence and r['twist'] == twist
                        and r['mode'] == 'slam' and r['fraction'] == fraction]
                if not slam or not dr:
                    continue
                ate = [r['ate_m'] for r in slam]
                ratio = [r['ate_m'] / d for r, d in zip(sorted(slam, key=lambda r: r['seed']), dr)]
                nees = [r.get('nees_position') for r in slam if r.get('nees_position') is not None]
                per_frame = [r['observations_per_frame'] for r in slam
                             if r.get('observations_per_frame') is not None]
                row = dict(sequence=sequence, twist=twist, fraction=fraction,
                           slam_ate_mean=float(np.mean(ate)), slam_ate_max=float(np.max(ate)),
                           dr_ate_mean=float(np.mean(dr)), ratio_mean=float(np.mean(ratio)),
                           ratio_max=float(np.max(ratio)),
                           nees_position=float(np.mean(nees)) if nees else None,
                           observations_per_frame=float(np.mean(per_frame)) if per_frame else None)
                rows.append(row)
                cells.append([sequence, twist, '%d %%' % round(100 * fraction),
                              fmt(row['observations_per_frame'], '.1f'),
                              fmt(row['slam_ate_mean'], '.2f'), fmt(row['slam_ate_max'], '.2f'),
                              fmt(row['dr_ate_mean'], '.2f'), fmt(row['ratio_mean'], '.2f'),
                              fmt(row['ratio_max'], '.2f'), fmt(row['nees_position'], '.1f')])
    header = ['sequence', 'twist', 'ids kept', 'updates per frame', 'SLAM ATE mean m', 'max m',
              'DR ATE m',
              'SLAM/DR mean', 'max', 'NEES pos']
    return rows, markdown_table(header, cells)


def plot(rows, sequences, path):
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, len(sequences), figsize=(5.5 * len(sequences), 4.2))
    for ax, sequence in zip(np.atleast_1d(axes), sequences):
        for twist, color in zip(TWISTS, ('tab:red', 'tab:blue')):
            sel = [r for r in rows if r['sequence'] == sequence and r['twist'] == twist]
            if not sel:
                continue
            x = [100 * r['fraction'] for r in sel]
            ax.plot(x, [r['slam_ate_mean'] for r in sel], 'o-', color=color,
                    label='SLAM, %s twist (mean, max)' % twist)
            ax.plot(x, [r['slam_ate_max'] for r in sel], 'v:', color=color, alpha=0.6)
            ax.axhline(sel[0]['dr_ate_mean'], color=color, ls='--',
                       label='dead reckoning, %s twist' % twist)
        ax.set_xscale('log')
        ax.set_xlabel('landmark ids kept, %')
        ax.set_ylabel('ATE RMSE, m')
        ax.set_title(sequence)
        ax.grid(True, which='both', alpha=0.3)
    np.atleast_1d(axes)[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def study_arguments(prog, name, doc, seeds_help=None):
    """The parser of a study's common options (data folder, sequences, output folder, seeds,
    options file, jobs, bags kept); the caller adds its own before parsing."""
    parser = argparse.ArgumentParser(prog=prog, description=doc.split('\n')[0])
    parser.add_argument('--data', default=os.environ.get(
        'EKF_VISLAM_DATA', os.path.join(HERE, '..', '..', 'shared', 'data')))
    parser.add_argument('--sequences', nargs='+', metavar='NAME',
                        help='datasets of the data folder (default: every one with ground truth)')
    parser.add_argument('--out', default=os.path.join(HERE, '..', 'results', name))
    parser.add_argument('--seeds', type=int, nargs='+', default=[1, 2, 3], help=seeds_help)
    parser.add_argument('--config', default=None, help='options YAML (default: the shipped one)')
    parser.add_argument('--jobs', type=int, default=2)
    parser.add_argument('--keep-bags', action='store_true',
                        help='keep each variant\'s bag under OUT/runs (about 70 MB each)')
    return parser


def study_sequences(prog, data, asked):
    """-> {name: (npz, ground truth)} of the asked sequences (default: every NAME.npz of the data
    folder with groundtruth/NAME_imu_gt.tum); exits naming what is missing."""
    found = {name: (npz, gt) for name, npz, gt in find_datasets(data) if gt}
    names = asked or sorted(found)
    missing = [name for name in names if name not in found]
    if not names or missing:
        sys.exit('%s: no NAME.npz with groundtruth/NAME_imu_gt.tum in %s for %s'
                 % (prog, data, ', '.join(missing) or 'any dataset'))
    return {name: found[name] for name in names}


def main(argv):
    parser = study_arguments('landmark_study.py', 'landmark_study', __doc__)
    parser.add_argument('--fractions', type=float, nargs='+',
                        default=[0.05, 0.1, 0.2, 0.4, 0.6, 0.8, 1.0])
    parser.add_argument('--accel-noise', type=float, default=None, metavar='SIGMA',
                        help='give every variant an accelerometer from the ground truth with '
                             'this white noise (m/s^2 per sample; default: none)')
    args = parser.parse_args(argv)
    sequences = list(study_sequences('landmark_study.py', args.data, args.sequences))
    out = os.path.abspath(args.out)
    binary = offline_binary()
    jobs = [(s, t, f, seed, 'slam') for s in sequences for t in TWISTS for f in args.fractions
            for seed in args.seeds]
    jobs += [(s, t, 1.0, seed, 'deadreckoning') for s in sequences for t in TWISTS
             for seed in args.seeds]
    # Dead reckoning shares the 100 % variant's bag: run it after the SLAM runs made it.
    start = time.monotonic()
    results = run_jobs(lambda j: one_run(j, args.data, out, binary, args.config,
                                         args.accel_noise), jobs, args.jobs)
    if not args.keep_bags:
        remove_bags(results)
    rows, text = summarize(results, sequences, args.fractions)
    wall = time.monotonic() - start
    plot(rows, sequences, os.path.join(out, 'landmark_study.png'))
    write_study(out, 'landmark_study', text, rows, results, wall, extra=('png',))
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
