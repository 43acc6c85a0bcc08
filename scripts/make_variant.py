#!/usr/bin/python3
"""Writes a regime variant of a course dataset.

    make_variant.py DATA.npz --groundtruth GT --twist course|accurate [--twist-noise V W]
                    [--gyro-offset B] [--speed-scale S]
                    [--accel-noise SIGMA [--accel-bias B [B B]]] [--keep-fraction F]
                    [--split-repeated] [--frames FIRST COUNT] [--seed N] --out OUT.npz

course: the file's own twist. accurate: the IMU body twist computed from the ground truth
(sample k+1 drives [t_k, t_k+1]) plus white noise of V m/s and W rad/s per sample and axis
(default 0.05, 0.005) and a constant gyro offset B rad/s on each axis (default 0.001), as good as
a decent wheel odometry. --speed-scale multiplies the linear velocity of either twist (noise
included) by S, as a wheel odometry whose wheel radius is off by S - 1 measures it (default 1).
--accel-noise (with either twist) adds an accelerometer, specific_force
(3,T) m/s^2 in the IMU frame: sample k is the mean specific force over (t_k-1, t_k] in the body
frame at t_k, from the ground-truth poses at the frame stamps and the noiseless ground-truth
velocity of the accurate twist, plus white noise of SIGMA m/s^2 per sample and axis and a constant
offset (--accel-bias, default 0). Gravity's direction: the ground truth's world is the first
camera frame, not level, so "up" is taken as the normalized mean of the IMU's z axis over the
drive (a stand-in: right when the drive's roll and pitch average out to zero). Its noise has its
own stream from --seed: the twist and the kept ids are the same with or without it.
--keep-fraction keeps a seeded random subset of the landmark ids.
--split-repeated empties each frame that re-publishes the previous one (the course files hold
8-13 %: more than half of the tracks both frames share have the same four coordinates) and gives
each track through it a new id after it. The course files' tracks are one image period off
after such a frame, which the estimator's repeated-frame handling knows only from the repeat
itself; without repeats a variant may drop frames (a camera slower than the twist:
dataset_to_bag.py --features-every N) without keeping a stale copy of a dropped frame.
--frames keeps COUNT frames from frame FIRST, first of all: a drive that starts elsewhere (at
speed, on a slope, in a turn), with the same ground truth (the stamps are the file's).
GT: a TUM file of world_T_imu, or a KITTI poses file of world_T_cam0 (a line per frame, turned
into world_T_imu with the dataset's cam_T_imu, corrected as dataset_to_bag.py does). Frames after
the last ground-truth pose are cut off. Every other key is kept as it is (the 2019
files' cam_T_imu included: dataset_to_bag.py corrects it).
"""
import argparse
import os
import sys

import numpy as np

from ekf_vislam_tools import dataset, variants


def main(argv):
    parser = argparse.ArgumentParser(prog='make_variant.py',
                                     description='Writes a regime variant of a course dataset.')
    parser.add_argument('dataset')
    parser.add_argument('--groundtruth', required=True, metavar='GT',
                        help='TUM file of world_T_imu, or KITTI poses (world_T_cam0, turned into '
                        'world_T_imu with the dataset\'s frame times and cam_T_imu)')
    parser.add_argument('--twist', choices=('course', 'accurate'), required=True)
    parser.add_argument('--twist-noise', nargs=2, type=float, default=(0.05, 0.005),
                        metavar=('V', 'W'), help='per-sample std, m/s and rad/s')
    parser.add_argument('--gyro-offset', type=float, default=0.001, metavar='B')
    parser.add_argument('--speed-scale', type=float, default=1.0, metavar='S',
                        help='multiply the twist\'s linear velocity by S (a wrong wheel radius)')
    parser.add_argument('--accel-noise', type=float, metavar='SIGMA',
                        help='add specific_force (accelerometer, m/s^2, IMU frame, gravity '
                        'included) from the ground truth with white noise of this std per '
                        'sample and axis; gravity\'s up = the mean IMU z axis over the drive (a '
                        'stand-in: the ground truth\'s world is the first camera frame, not '
                        'level); default: none')
    parser.add_argument('--accel-bias', type=float, nargs='+', metavar='B',
                        help='with --accel-noise: constant accelerometer offset, one value for all '
                        'axes or three (m/s^2; default 0)')
    parser.add_argument('--keep-fraction', type=float, default=1.0, metavar='F')
    parser.add_argument('--split-repeated', action='store_true',
                        help='empty the repeated frames and give the tracks through each a new '
                        'id after it')
    parser.add_argument('--frames', type=int, nargs=2, metavar=('FIRST', 'COUNT'),
                        help='keep COUNT frames from frame FIRST (a section of the drive)')
    parser.add_argument('--seed', type=int, default=0)
    parser.add_argument('--out', required=True, metavar='OUT.npz')
    args = parser.parse_args(argv)
    if args.accel_bias is not None and len(args.accel_bias) not in (1, 3):
        parser.error('--accel-bias takes one value or three')
    if args.accel_bias is not None and args.accel_noise is None:
        parser.error('--accel-bias needs --accel-noise')
    try:
        # Validated, and its cam_T_imu corrected as dataset_to_bag.py does (for KITTI poses).
        checked = dataset.load_dataset(args.dataset, fix_twist_axes=False)
        with np.load(args.dataset, allow_pickle=False) as archive:
            data = {key: archive[key] for key in archive.files}
        out, notes = variants.make_variant(data, args.groundtruth, args.twist,
                                           tuple(args.twist_noise), args.gyro_offset,
                                           args.keep_fraction, args.seed, args.accel_noise,
                                           0.0 if args.accel_bias is None else args.accel_bias,
                                           cam_T_imu=checked.cam_T_imu,
                                           split_repeated=args.split_repeated,
                                           speed_scale=args.speed_scale,
                                           frames=args.frames)
        tmp = args.out + '.tmp.npz'
        np.savez(tmp, **out)
        os.replace(tmp, args.out)
    except (OSError, ValueError) as error:
        print('make_variant.py: %s' % ' '.join(str(error).split()), file=sys.stderr)
        return 2
    print('wrote %s: %s' % (args.out, '; '.join(notes) or 'unchanged'))
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
