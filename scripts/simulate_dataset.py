#!/usr/bin/python3
"""Simulate a KITTI-like stereo visual-inertial drive as a course dataset with ground truth.

    simulate_dataset.py --seed N --out PREFIX [--frames N | --length-m L] [--pixel-noise PX]
                        [--outlier-rate R] [--velocity-noise V] [--gyro-noise W] [--gyro-bias B]
                        [--accel-noise SIGMA [--accel-bias B [B B]]]
                        [--vehicles-ahead N] [--oncoming-per-minute R]

Writes PREFIX.npz (2019 course layout with a correct cam_T_imu, marked by
cam_T_imu_translation_correct = True, and image_size), PREFIX_groundtruth.tum (world_T_imu, first
pose = identity, times = the npz stamps) and PREFIX_landmarks.csv (id,x,y,z in the world frame).
With --accel-noise the npz also holds specific_force (3,T): the accelerometer, m/s^2, in the IMU
frame, sample k the mean specific force over (t_k-1, t_k] (gravity included) plus the offset and
white noise; without it there is no such field.
The simulation itself is ekf_vislam_tools.simulator; the same seed gives the same files.
"""
import argparse
import sys

from ekf_vislam_tools import simulator

PROG = 'simulate_dataset.py'
EXIT_OK, EXIT_FAILURE, EXIT_BAD_INPUT = 0, 1, 2


def parse_args(argv):
    d = simulator.DEFAULT_OPTIONS
    parser = argparse.ArgumentParser(
        prog=PROG, description='Simulate a KITTI-like stereo visual-inertial drive: writes '
        'PREFIX.npz (course 2019 layout), PREFIX_groundtruth.tum and PREFIX_landmarks.csv.')
    parser.add_argument('--seed', type=int, default=0, help='random seed (default %(default)s)')
    parser.add_argument('--out', required=True, metavar='PREFIX', help='output file prefix')
    length = parser.add_mutually_exclusive_group()
    length.add_argument('--frames', type=int, default=d['frames'],
                        help='number of frames (default %(default)s)')
    length.add_argument('--length-m', type=float, help='drive this many metres instead')
    noise = parser.add_argument_group('noise')
    noise.add_argument('--pixel-noise', type=float, default=d['pixel_noise'], metavar='PX',
                       help='std of each pixel coordinate (default %(default)s px)')
    noise.add_argument('--pixel-correlation', type=float, default=d['pixel_correlation'],
                       metavar='RHO', help='drifting tracks: correlation of a track\'s pixel '
                       'error from one frame to the next, AR(1) (default %(default)s: white)')
    noise.add_argument('--drift-expansion', type=float, default=d['drift_expansion'],
                       metavar='E', help='systematic track drift: px per frame of a track\'s age '
                       'per unit of normalized image x, in u (KITTI course tracks: 0.18-0.28; '
                       'default %(default)s)')
    noise.add_argument('--drift-v', type=float, default=d['drift_v'], metavar='D',
                       help='systematic track drift in v, px per frame of age (KITTI course '
                       'tracks: -0.04 to -0.06; default %(default)s)')
    noise.add_argument('--disparity-offset', type=float, default=d['disparity_offset'],
                       metavar='PX', help='measured minus true disparity: every u_right moved '
                       'left by PX (a rig whose rectification is off; default %(default)s)')
    noise.add_argument('--outlier-rate', type=float, default=d['outlier_rate'], metavar='R',
                       help='fraction of gross outlier observations (default %(default)s)')
    noise.add_argument('--velocity-noise', type=float, default=d['velocity_noise'], metavar='V',
                       help='std of each linear velocity component (default %(default)s m/s)')
    noise.add_argument('--gyro-noise', type=float, default=d['gyro_noise'], metavar='W',
                       help='std of each angular velocity component (default %(default)s rad/s)')
    noise.add_argument('--gyro-bias', type=float, nargs='+', metavar='B',
                       help='constant gyro offset, one value for all axes or three (rad/s); '
                            'default: each axis drawn from +-[0.005, 0.01] by the seed')
    noise.add_argument('--accel-noise', type=float, metavar='SIGMA',
                       help='write an accelerometer (specific_force, m/s^2, gravity included) '
                       'with white noise of this std per component and sample (default: none)')
    noise.add_argument('--accel-bias', type=float, nargs='+', metavar='B',
                       help='with --accel-noise: constant accelerometer offset, one value for all '
                       'axes or three (m/s^2; default 0)')
    scene = parser.add_argument_group('drive and scene')
    scene.add_argument('--rate-hz', type=float, default=d['rate_hz'],
                       help='frame rate (default %(default)s Hz)')
    scene.add_argument('--start-time', type=float, default=d['start_time'],
                       help='first time stamp (default %(default).0f s)')
    scene.add_argument('--speed-min', type=float, default=d['speed_min'],
                       help='lowest forward speed (default %(default)s m/s)')
    scene.add_argument('--speed-max', type=float, default=d['speed_max'],
                       help='highest forward speed (default %(default)s m/s)')
    scene.add_argument('--max-yaw-rate', type=float, default=d['max_yaw_rate'],
                       help='peak yaw rate of the sharpest turns (default %(default)s rad/s)')
    scene.add_argument('--roll-amplitude', type=float, default=d['roll_amplitude'],
                       metavar='DEG', help='peak roll against the level (default %(default)s deg)')
    scene.add_argument('--pitch-amplitude', type=float, default=d['pitch_amplitude'],
                       metavar='DEG', help='peak pitch against the level, hills and dips '
                       '(default %(default)s deg)')
    scene.add_argument('--target-obs', type=int, default=d['target_obs'],
                       help='observations per frame aimed at (default %(default)s)')
    scene.add_argument('--track-loss', type=float, default=d['track_loss'],
                       help='per-frame probability of losing a visible track '
                            '(default %(default)s)')
    scene.add_argument('--landmark-density', type=float, default=d['landmark_density'],
                       help='landmarks per metre of road (default %(default)s)')
    scene.add_argument('--max-depth', type=float, default=d['max_depth'],
                       help='farthest observable depth (default %(default)s m)')
    scene.add_argument('--stop', type=float, nargs=2, action='append', default=[],
                       metavar=('START', 'DURATION'), dest='stops',
                       help='the vehicle comes to rest at START s after the drive starts (slowing '
                            'over the 3 s before) and waits DURATION s; at rest the linear '
                            'velocity reads exactly 0, as a wheel odometry does (repeatable)')
    scene.add_argument('--vehicles-ahead', type=int, default=d['vehicles_ahead'], metavar='N',
                       help='traffic: N cars drive 10-35 m ahead (ego lane or the left one), their '
                            'corners tracked too (default %(default)s)')
    scene.add_argument('--oncoming-per-minute', type=float, default=d['oncoming_per_minute'],
                       metavar='R', help='traffic: oncoming cars per minute in the left lane, '
                       '8-14 m/s, their corners tracked too (default %(default)s)')
    args = parser.parse_args(argv)
    if args.gyro_bias is not None and len(args.gyro_bias) not in (1, 3):
        parser.error('--gyro-bias takes one value or three')
    if args.accel_bias is not None and len(args.accel_bias) not in (1, 3):
        parser.error('--accel-bias takes one value or three')
    if args.accel_bias is not None and args.accel_noise is None:
        parser.error('--accel-bias needs --accel-noise')
    if args.out.endswith('.npz'):
        args.out = args.out[:-len('.npz')]
    return args


def main(argv=None):
    args = parse_args(sys.argv[1:] if argv is None else argv)
    options = {name: getattr(args, name) for name in (
        'frames', 'length_m', 'pixel_noise', 'pixel_correlation', 'drift_expansion', 'drift_v',
        'disparity_offset', 'outlier_rate',
        'velocity_noise', 'gyro_noise', 'gyro_bias', 'rate_hz', 'start_time', 'speed_min',
        'speed_max', 'max_yaw_rate', 'roll_amplitude', 'pitch_amplitude', 'target_obs',
        'track_loss', 'landmark_density', 'max_depth', 'accel_noise', 'accel_bias',
        'vehicles_ahead', 'oncoming_per_minute')}
    options['stops'] = tuple(tuple(stop) for stop in args.stops)
    try:
        result = simulator.simulate(args.seed, **options)
    except ValueError as exc:
        print('%s: error: %s' % (PROG, exc), file=sys.stderr)
        return EXIT_BAD_INPUT
    try:
        paths = simulator.write_outputs(result, args.out)
    except OSError as exc:
        print('%s: error: cannot write %s* (%s)' % (PROG, args.out, exc.strerror or exc),
              file=sys.stderr)
        return EXIT_FAILURE
    print('%s: seed %d: %s -> %s, %s, %s' % (PROG, args.seed, simulator.summary(result),
                                              paths['npz'], paths['groundtruth'],
                                              paths['landmarks']))
    return EXIT_OK


if __name__ == '__main__':
    sys.exit(main())
