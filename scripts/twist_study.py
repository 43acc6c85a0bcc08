#!/usr/bin/python3
"""The twist study: SLAM and dead reckoning with twists of other noise, every drive whole.

    twist_study.py [--data DIR] [--sequences NAME ...] [--out DIR] [--twists TWIST ...]
                   [--seeds N ...] [--config YAML] [--jobs 2] [--keep-bags]

The shipped configuration has one guess of the twist's noise for every dataset; the filter reads
the noise of the twist it is given online. This study checks that guess against twists it was not
made for: for every dataset of the data folder with ground truth (NAME.npz and
groundtruth/NAME_imu_gt.tum), each TWIST is either "course" (the file's own twist, run once) or
"V,W,B": a twist made from the ground truth with V m/s and W rad/s of white noise per component
and sample and a constant gyro offset of B rad/s on every axis (make_variant.py --twist accurate
--twist-noise V W --gyro-offset B), one draw per seed. Each runs in SLAM and dead reckoning.
Writes OUT/twist_study.md (per dataset and twist: SLAM ATE mean and max over the seeds, dead
reckoning's, their ratio, SLAM's mean position and pose NEES and the worst seed's) and
OUT/twist_study.json, and prints the table and the wall time.

The default twists: the accurate one of the other studies (0.05 m/s, 0.005 rad/s, 0.001 rad/s),
a fair wheel odometry (0.2, 0.02, 0.003), the course files' noise and gyro offset as white noise
(0.5, 0.05, 0.009), twice the course's noise (1.0, 0.1), four times its angular noise (0.5, 0.2)
and four times its linear noise (2.0, 0.05).
"""
import os
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, '..', 'src'))
sys.path.insert(0, HERE)
from benchmark import offline_binary  # noqa: E402
from ekf_vislam_tools.report import markdown_table  # noqa: E402
from landmark_study import (remove_bags, run_jobs, run_variant, study_arguments,  # noqa: E402
                            study_sequences, write_study)
from section_study import OVER_SEEDS_HEADER, by_seed, over_seeds, over_seeds_cells  # noqa: E402

COURSE = 'course'
DEFAULT_TWISTS = [COURSE, '0.05,0.005,0.001', '0.2,0.02,0.003', '0.5,0.05,0.009',
                  '1.0,0.1,0.009', '0.5,0.2,0.009', '2.0,0.05,0.009']


def parse_twist(text):
    """'course' -> None; 'V,W,B' -> (V, W, B) (m/s, rad/s, rad/s), each >= 0."""
    if text == COURSE:
        return None
    try:
        values = tuple(float(v) for v in text.split(','))
    except ValueError:
        values = ()
    if len(values) != 3 or min(values) < 0:
        raise ValueError('a twist is "course" or "V,W,B" (three numbers >= 0), not %r' % text)
    return values


def variant_arguments(twist):
    """make_variant's arguments of a twist ('course' or 'V,W,B')."""
    noise = parse_twist(twist)
    if noise is None:
        return dict(twist=COURSE)
    return dict(twist='accurate', twist_noise=noise[:2], gyro_offset=noise[2])


def one_run(job, data, out, binary, config):
    """job = (sequence, twist, seed, mode) -> result dict."""
    sequence, twist, seed, mode = job
    folder = os.path.join(out, 'runs', '%s_%s_s%d' % (sequence, twist.replace(',', '_'), seed))
    result = dict(sequence=sequence, twist=twist, seed=seed, mode=mode)
    result.update(run_variant(folder, data, sequence, mode, binary, config, seed=seed,
                              **variant_arguments(twist)))
    return result


def summarize(results, twists):
    """-> (rows, markdown table): one row per sequence and twist (in the order asked), over the
    seeds."""
    rows, cells = [], []
    for sequence in sorted({r['sequence'] for r in results}):
        for twist in twists:
            runs = [r for r in results if (r['sequence'], r['twist']) == (sequence, twist)]
            slam, dr = by_seed(runs, 'slam'), by_seed(runs, 'deadreckoning')
            if not slam or len(slam) != len(dr):
                continue
            row = dict(sequence=sequence, twist=twist)
            row.update(over_seeds(slam, dr))
            rows.append(row)
            label = twist if twist == COURSE else ' / '.join(twist.split(','))
            cells.append([sequence, label] + over_seeds_cells(row))
    header = ['sequence', 'twist (m/s / rad/s / gyro offset rad/s)'] + OVER_SEEDS_HEADER
    return rows, markdown_table(header, cells)


def main(argv):
    parser = study_arguments('twist_study.py', 'twist_study', __doc__,
                             seeds_help='draws of each made twist (the course twist runs once)')
    parser.add_argument('--twists', nargs='+', default=DEFAULT_TWISTS, metavar='TWIST',
                        help='"course" or "V,W,B" (default: %s)' % ' '.join(DEFAULT_TWISTS))
    args = parser.parse_args(argv)
    try:
        for twist in args.twists:
            parse_twist(twist)
    except ValueError as exc:
        parser.error(str(exc))
    found = study_sequences('twist_study.py', args.data, args.sequences)
    out = os.path.abspath(args.out)
    binary = offline_binary()
    jobs = [(name, twist, seed, mode) for name in found for twist in args.twists
            for seed in (args.seeds[:1] if twist == COURSE else args.seeds)
            for mode in ('slam', 'deadreckoning')]
    start = time.monotonic()
    results = run_jobs(lambda j: one_run(j, args.data, out, binary, args.config), jobs, args.jobs)
    if not args.keep_bags:
        remove_bags(results)
    rows, text = summarize(results, args.twists)
    write_study(out, 'twist_study', text, rows, results, time.monotonic() - start)
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
