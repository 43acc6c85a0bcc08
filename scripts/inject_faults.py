#!/usr/bin/python3
"""Writes a fault-injected copy of an estimator input bag.

    inject_faults.py CLEAN.bag FAULTY.bag [--outlier-fraction F] [--empty-every N] [--seed S]

One instance of each fault class the estimator handles (NaN, implausible, duplicate and backwards
twists, a swapped twist pair, features before any twist, NaN / negative-disparity / duplicate /
row-mismatched features, a 10,000-feature message), plus gross outliers and periodic empty
feature messages when asked. Compare `vislam_offline` on both bags to see what the faults cost.
"""
import argparse
import sys

from ekf_vislam_tools.faults import inject_faults


def main(argv):
    parser = argparse.ArgumentParser(prog='inject_faults.py', description=__doc__.split('\n')[0])
    parser.add_argument('clean_bag')
    parser.add_argument('faulty_bag')
    parser.add_argument('--outlier-fraction', type=float, default=0.0,
                        help='fraction of observations moved to random image positions')
    parser.add_argument('--empty-every', type=int, default=0, metavar='N',
                        help='an empty feature message every N frames (0: only one)')
    parser.add_argument('--seed', type=int, default=1)
    args = parser.parse_args(argv)
    try:
        expected = inject_faults(args.clean_bag, args.faulty_bag, args.outlier_fraction,
                                 args.empty_every, args.seed)
    except Exception as error:  # one line, no traceback
        print('inject_faults.py: %s' % error, file=sys.stderr)
        return 1
    print('wrote %s (minimum counts: %s)' % (args.faulty_bag, ', '.join(
        '%s %d' % item for item in sorted(expected.items()))))
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
