#!/usr/bin/python3
"""Error statistics of a dataset's feature tracks against ground-truth poses.

    track_error_stats.py DATA.npz --groundtruth GT [--json OUT.json]
    track_error_stats.py DATA.npz --poses RUN/trajectory.tum [--json OUT.json]

GT holds world_T_imu (TUM; frames matched to the dataset by time stamp) or is a KITTI poses file
(world_T_cam0, a line per dataset frame). Without ground truth,
--poses takes the estimator's own trajectory (vislam_offline's trajectory.tum of a SLAM run): the
correlation and the random-walk rate read nearly as against ground truth (the estimate's own
error adds to the white part and the std). Each track gets the
landmark that best fits all its stereo observations from the ground-truth poses; its residuals
are its pixel errors. Prints their std, their correlation from one frame to the next (the
value of noise/pixel_correlation that describes them), their random-walk rate (the value of
noise/track_random_walk: px/sqrt(s) from the variogram over 1-3 frames), the part shared by the
tracks of a frame, and the mean drift per frame by image region (ekf_vislam_tools/
track_errors.py). The residuals also carry the ground truth's own pose error.

Exit status: 0 on success, 2 on unusable input (one-line message on stderr).
"""
import argparse
import json
import sys

import numpy as np

from ekf_vislam_tools import dataset, track_errors


def report(stats):
    names = 'uL vL uR vR'
    fmt = lambda values: ' '.join('%.3f' % v for v in values)  # noqa: E731
    lines = ['%d tracks, %d observations (%.1f %% inliers within %.0f px)' % (
        stats['tracks'], stats['observations'], 100 * stats['inlier_fraction'],
        track_errors.INLIER_PX),
        'std (%s): %s px' % (names, fmt(stats['std'])),
        'shared by the tracks of a frame, std: %s px' % fmt(stats['frame_common_std'])]
    for lag, values in stats['correlation'].items():
        lines.append('correlation at lag %d: %s (without the frame-shared part: %s)' % (
            lag, fmt(values), fmt(stats['correlation_without_frame_common'][lag])))
    lines.append('frame-to-frame correlation rho = %.3f; std of e_k - rho e_(k-1): %s px' % (
        stats['rho'], fmt(stats['differenced_std'])))
    lines.append('disparity error correlation at lag 1: %.3f' % stats['disparity_correlation'])
    walk = stats['random_walk']
    lines.append('random walk: variance of e_(k+L) - e_k for L = %s: %s px^2 (uL, vL); per frame '
                 '%s px^2 (a white part of %s px^2): noise/track_random_walk %.2f px/sqrt(s) '
                 'at the median frame period %.3f s' % (
                     '/'.join(str(lag) for lag in walk['lags']),
                     ' / '.join(fmt(v[:2]) for v in walk['variogram_px2']),
                     fmt(walk['step_variance_px2_per_frame']), fmt(walk['white_variance_px2']),
                     walk['rate_px_per_sqrt_s'], walk['frame_period_s']))
    drift = stats['drift_per_frame']
    lines.append('mean drift per frame: %s px (standard error %s)' % (
        fmt(drift['all']), fmt(drift['standard_error'])))
    for key, label in (('by_row', 'image rows'), ('by_column', 'image columns')):
        for b in drift[key]:
            lines.append('  %s %4.0f-%4.0f (%6d): %s' % (label, b['range_px'][0],
                                                         b['range_px'][1], b['count'],
                                                         fmt(b['mean'])))
    spread = stats['per_track']
    if spread['tracks']:
        lines.append('per track (%d tracks of %d+ observations): RMS %s px, |drift| %s px per '
                     'frame (percentiles %s); the worst 10 %% hold %.0f %% of the squared error, '
                     'the worst 25 %% %.0f %%' % (
                         spread['tracks'], track_errors.PER_TRACK_MIN,
                         fmt(spread['rms_percentiles_px']),
                         fmt(spread['drift_percentiles_px_per_frame']),
                         '/'.join(str(p) for p in track_errors.PERCENTILES),
                         100 * spread['worst_10_percent_share'],
                         100 * spread['worst_25_percent_share']))
    return '\n'.join(lines)


def main(argv):
    parser = argparse.ArgumentParser(prog='track_error_stats.py', description=__doc__.split(
        '\n')[0])
    parser.add_argument('dataset')
    parser.add_argument('--groundtruth', '--poses', dest='groundtruth', required=True,
                        metavar='GT', help='world_T_imu poses (TUM): the ground truth, or the '
                        'estimator\'s own trajectory.tum; or KITTI poses of world_T_cam0')
    parser.add_argument('--json', metavar='OUT.json', help='also write the figures as JSON')
    args = parser.parse_args(argv)
    try:
        data = dataset.load_dataset(args.dataset, fix_twist_axes=False)  # the twist is not used
        residual, frame, track, z = track_errors.track_residuals(
            data.features, track_errors.camera_poses(data, args.groundtruth), data.K, data.b)
        stats = track_errors.statistics(residual, frame, track, z)
        walk = stats['random_walk']
        walk['frame_period_s'] = float(np.median(np.diff(data.t)))
        # Image axes uL and vL (uR, vR repeat them); negative steps read as no random walk.
        step = max(0.0, float(np.mean(walk['step_variance_px2_per_frame'][:2])))
        walk['rate_px_per_sqrt_s'] = float(np.sqrt(step / walk['frame_period_s']))
    except (OSError, ValueError) as error:
        print('track_error_stats.py: %s' % ' '.join(str(error).split()), file=sys.stderr)
        return 2
    print(report(stats))
    if args.json:
        with open(args.json, 'w') as f:
            json.dump(stats, f, indent=1)
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
