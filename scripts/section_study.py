#!/usr/bin/python3
"""The section study: SLAM and dead reckoning over sections of each drive, each run on its own.

    section_study.py [--data DIR] [--sequences NAME ...] [--out DIR] [--sections N]
                     [--seeds N ...] [--config YAML] [--jobs 2] [--keep-bags]

A drive that starts elsewhere is another regime of the same real tracks: at speed, in a turn, on
a slope, with the filter's online estimates (twist noise, track correlation) starting from
nothing, and its covariance measured against the ground truth over tens of seconds instead of
minutes. For every dataset of the data folder with ground truth (NAME.npz and
groundtruth/NAME_imu_gt.tum), the frames with ground truth are cut into N equal sections
(make_variant.py --frames), each run with both twists (the file's own, "course", once; the
accurate one, ground truth + 0.05 m/s / 0.005 rad/s white noise and a 0.001 rad/s gyro offset,
per seed) in SLAM and dead reckoning. Writes OUT/section_study.md (per section: path, SLAM ATE
mean and max over the seeds, dead reckoning's, their ratio, SLAM's mean position and pose NEES
and the worst seed's) and OUT/section_study.json, and prints the table and the wall time.
"""
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, '..', 'src'))
sys.path.insert(0, HERE)
from benchmark import offline_binary  # noqa: E402
from ekf_vislam_tools import dataset, trajectory, variants  # noqa: E402
from ekf_vislam_tools.report import fmt, markdown_table  # noqa: E402
from landmark_study import (TWISTS, remove_bags, run_jobs, run_variant,  # noqa: E402
                            study_arguments, study_sequences, write_study)


def sections(num_frames, count):
    """(first, frames) of `count` equal sections of num_frames (the last takes the remainder)."""
    size = num_frames // count
    if size < 2:
        raise ValueError('%d frames cannot make %d sections' % (num_frames, count))
    return [(k * size, size if k < count - 1 else num_frames - k * size) for k in range(count)]


def one_run(job, data, out, binary, config):
    """job = (sequence, twist, (first, frames), seed, mode) -> result dict."""
    sequence, twist, (first, frames), seed, mode = job
    folder = os.path.join(out, 'runs', '%s_%s_%05d_s%d' % (sequence, twist, first, seed))
    result = dict(sequence=sequence, twist=twist, first=first, frames=frames, seed=seed, mode=mode)
    result.update(run_variant(folder, data, sequence, mode, binary, config, twist=twist,
                              seed=seed, frames=(first, frames)))
    return result


def over_seeds(slam, dr):
    """-> dict of one regime's runs over the seeds: SLAM ATE mean and max, dead reckoning's mean,
    the ratio of each seed's SLAM to its dead reckoning (mean, max), SLAM's position and pose NEES
    (mean, worst seed) and dead reckoning's position NEES. slam and dr: the runs, same seeds."""
    ratio = [s['ate_m'] / d['ate_m'] for s, d in zip(slam, dr)]
    row = dict(seeds=len(slam), path_m=slam[0]['path_length_m'],
               slam_ate_mean=float(np.mean([r['ate_m'] for r in slam])),
               slam_ate_max=float(np.max([r['ate_m'] for r in slam])),
               dr_ate_mean=float(np.mean([r['ate_m'] for r in dr])),
               ratio_mean=float(np.mean(ratio)), ratio_max=float(np.max(ratio)))
    for name in ('nees_position', 'nees_pose'):
        values = [r[name] for r in slam if r.get(name) is not None]
        row[name] = float(np.mean(values)) if values else None
        row[name + '_max'] = float(np.max(values)) if values else None
    dr_nees = [r['nees_position'] for r in dr if r.get('nees_position') is not None]
    row['dr_nees_position'] = float(np.mean(dr_nees)) if dr_nees else None
    return row


OVER_SEEDS_HEADER = ['path m', 'seeds', 'SLAM ATE mean m', 'max m', 'DR ATE m', 'SLAM/DR mean',
                     'max', 'NEES pos mean', 'max', 'NEES pose mean', 'max', 'DR NEES pos']


def over_seeds_cells(row):
    """The table cells of an over_seeds row, in OVER_SEEDS_HEADER's order."""
    return [fmt(row['path_m'], '.0f'), '%d' % row['seeds'], fmt(row['slam_ate_mean'], '.3f'),
            fmt(row['slam_ate_max'], '.3f'), fmt(row['dr_ate_mean'], '.3f'),
            fmt(row['ratio_mean'], '.2f'), fmt(row['ratio_max'], '.2f'),
            fmt(row['nees_position'], '.2f'), fmt(row['nees_position_max'], '.2f'),
            fmt(row['nees_pose'], '.2f'), fmt(row['nees_pose_max'], '.2f'),
            fmt(row['dr_nees_position'], '.2f')]


def by_seed(runs, mode):
    return sorted((r for r in runs if r['mode'] == mode), key=lambda r: r['seed'])


def summarize(results):
    """-> (rows, markdown table): one row per sequence, twist and section, over the seeds."""
    rows, cells = [], []
    keys = sorted({(r['sequence'], r['twist'], r['first'], r['frames']) for r in results},
                  key=lambda k: (k[0], TWISTS.index(k[1]), k[2]))
    for sequence, twist, first, frames in keys:
        runs = [r for r in results if (r['sequence'], r['twist'], r['first']) ==
                (sequence, twist, first)]
        slam, dr = by_seed(runs, 'slam'), by_seed(runs, 'deadreckoning')
        if not slam or len(slam) != len(dr):
            continue
        row = dict(sequence=sequence, twist=twist, first=first, frames=frames)
        row.update(over_seeds(slam, dr))
        rows.append(row)
        cells.append([sequence, twist, '%d-%d' % (first, first + frames - 1)]
                     + over_seeds_cells(row))
    return rows, markdown_table(['sequence', 'twist', 'frames'] + OVER_SEEDS_HEADER, cells)


def main(argv):
    parser = study_arguments('section_study.py', 'section_study', __doc__,
                             seeds_help='seeds of the accurate twist (the course twist runs once)')
    parser.add_argument('--sections', type=int, default=4, metavar='N')
    args = parser.parse_args(argv)
    found = study_sequences('section_study.py', args.data, args.sequences)
    out = os.path.abspath(args.out)
    binary = offline_binary()
    jobs = []
    for name, (npz, gt) in found.items():
        data = dataset.load_dataset(npz, fix_twist_axes=False)  # a clear error, not a run's
        covered = variants.frames_with_groundtruth(data.t, trajectory.read_tum(gt)[0])
        for section in sections(covered, args.sections):
            for twist in TWISTS:
                for seed in (args.seeds if twist == 'accurate' else args.seeds[:1]):
                    jobs += [(name, twist, section, seed, mode)
                             for mode in ('slam', 'deadreckoning')]
    start = time.monotonic()
    results = run_jobs(lambda j: one_run(j, args.data, out, binary, args.config), jobs, args.jobs)
    if not args.keep_bags:
        remove_bags(results)
    rows, text = summarize(results)
    write_study(out, 'section_study', text, rows, results, time.monotonic() - start)
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
