#!/usr/bin/python3
"""Evaluate estimated trajectories (and the map) against ground truth: ATE, RPE, plots.

  rosrun ekf_vislam evaluate.py --estimate trajectory.tum --groundtruth GT.tum --out DIR \\
      [--landmarks landmarks.csv --landmarks-gt true_landmarks.csv]
  rosrun ekf_vislam evaluate.py --groundtruth GT.tum --out DIR \\
      --estimate A.tum --label slam --estimate B.tum --label mapping

Estimates are TUM files of estworld_T_imu; the ground truth is a TUM file of gtworld_T_imu (or a
KITTI poses file of world_T_cam0 with --dataset, or with --frame-times and --cam-T-imu). Poses
are associated by time stamp, each estimate is aligned to the ground truth (Umeyama, rigid, no
scale) and the metrics of ekf_vislam_tools.metrics are computed. The first estimate is the
primary one: its alignment also moves the landmarks. Writes DIR/metrics.json,
DIR/trajectory_topdown.png, DIR/error_along_path.png and, with several estimates,
DIR/comparison.png. An estimate with trajectory_covariance.txt beside it (vislam_offline's) also
gets DIR/consistency_LABEL.csv and .png: per pose, the position and pose NEES and, per world axis,
the error and the reported sigma (where the covariance is too narrow, not only by how much).

Exit status: 0 on success, 2 on unusable input (one-line message on stderr).
"""
import argparse
import json
import math
import os
import re
import sys
import warnings

import numpy as np

try:
    from ekf_vislam_tools import dataset, metrics, plots, trajectory
except ImportError:  # run from a source checkout without the sourced workspace
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', 'src'))
    from ekf_vislam_tools import dataset, metrics, plots, trajectory

PROG = 'evaluate.py'


class UsageError(Exception):
    """Unusable input; the message is printed as one line and the exit status is 2."""


class _EstimateAction(argparse.Action):
    """--estimate PATH appends a new estimate; its label may follow with --label."""

    def __call__(self, parser, namespace, value, option_string=None):
        estimates = list(getattr(namespace, 'estimates', None) or [])
        estimates.append({'path': value, 'label': None})
        namespace.estimates = estimates


class _LabelAction(argparse.Action):
    """--label NAME names the estimate given just before it."""

    def __call__(self, parser, namespace, value, option_string=None):
        estimates = getattr(namespace, 'estimates', None)
        if not estimates:
            parser.error('--label %s must follow the --estimate it names' % value)
        if estimates[-1]['label'] is not None:
            parser.error('--label %s: the estimate %s already has the label %s'
                         % (value, estimates[-1]['path'], estimates[-1]['label']))
        estimates[-1]['label'] = value


def parse_args(argv):
    parser = argparse.ArgumentParser(
        prog=PROG, description=__doc__.split('\n')[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog='metrics (see ekf_vislam_tools.metrics): ATE RMSE/mean/median/max of the position\n'
               'errors after a rigid Umeyama alignment (no scale), rotation RMSE (after the\n'
               'rotation that best maps the estimated orientations onto the true ones), KITTI RPE\n'
               'over 100..800 m segments every 10 frames (null below 100 m), final position error;\n'
               'landmarks: errors after the primary alignment, matched by id; in the estimator\'s\n'
               'gauge (its first pose on the ground truth\'s), the squared Mahalanobis errors\n'
               '(diagonal per-axis sigmas): their mean (NEES, 3 is consistent), the fraction\n'
               '<= 14.16 (chi-square, 3 dof, at 0.9973 = the 1-D 3-sigma probability), and the\n'
               'RMS of error / sigma per axis. Real data: --landmarks-gt from\n'
               'landmark_reference.py (the tracks triangulated with the ground-truth poses).\n'
               'exit status 2 with a one-line message on unusable input.')
    parser.add_argument('--estimate', action=_EstimateAction, dest='estimates', metavar='TUM',
                        required=True, help='estimated trajectory (TUM, estworld_T_imu); '
                        'repeat to compare several; the first is the primary one')
    parser.add_argument('--label', action=_LabelAction, metavar='NAME',
                        help='name of the preceding --estimate (default: its parent folder name)')
    parser.add_argument('--groundtruth', required=True, metavar='FILE',
                        help='ground truth: TUM (gtworld_T_imu) or KITTI poses (world_T_cam0, '
                        'needs --dataset, or --frame-times and --cam-T-imu)')
    parser.add_argument('--dataset', metavar='NPZ',
                        help='for KITTI ground truth: the course dataset the run came from; its '
                        'frame times and cam_T_imu (translation corrected as dataset_to_bag.py '
                        'does) turn the poses into world_T_imu')
    parser.add_argument('--frame-times', metavar='FILE',
                        help='for KITTI ground truth: time stamp of each frame, as a text file '
                        '(one per line) or a dataset .npz (key time_stamps or t)')
    parser.add_argument('--cam-T-imu', metavar='FILE',
                        help='for KITTI ground truth: text file with the 4x4 (or 3x4) cam_T_imu')
    parser.add_argument('--landmarks', metavar='CSV',
                        help='landmarks of the primary estimate: id,x,y,z,sigma_x,sigma_y,sigma_z,'
                        'observations (estimator world)')
    parser.add_argument('--landmarks-gt', metavar='CSV',
                        help='true landmarks: id,x,y,z (ground-truth world)')
    parser.add_argument('--max-dt', type=float, default=0.02, metavar='S',
                        help='association tolerance on time stamps (default: %(default)s s)')
    parser.add_argument('--topdown-axes', default='auto', metavar='AB',
                        help='ground-truth world axes of the top-down plots, e.g. xy or xz; auto '
                        '(default) looks down along the mean up axis (z) of the IMU poses')
    parser.add_argument('--out', required=True, metavar='DIR', help='output directory')
    args = parser.parse_args(argv)
    if args.landmarks_gt and not args.landmarks:
        parser.error('--landmarks-gt needs --landmarks')
    if bool(args.frame_times) != bool(args.cam_T_imu):
        parser.error('--frame-times and --cam-T-imu go together')
    if args.dataset and args.frame_times:
        parser.error('--dataset gives the frame times and cam_T_imu: not with --frame-times')
    if not args.max_dt > 0:
        parser.error('--max-dt must be positive')
    if args.topdown_axes != 'auto':
        try:
            plots.parse_axes(args.topdown_axes)
        except ValueError as exc:
            parser.error(str(exc))
    assign_labels(args.estimates)
    return args


def assign_labels(estimates):
    """Default labels (parent folder name) and unique labels (suffix -2, -3, ...)."""
    used = set()
    for est in estimates:
        label = est['label']
        if not label:
            folder = os.path.basename(os.path.dirname(os.path.abspath(est['path'])))
            label = folder or os.path.splitext(os.path.basename(est['path']))[0]
        unique, n = label, 2
        while unique in used:
            unique, n = '%s-%d' % (label, n), n + 1
        used.add(unique)
        est['label'] = unique


def _one_line(exc):
    return ' '.join(str(exc).split('\n'))


def load_text_matrix(path, what):
    """Numbers of a text file, raising UsageError naming the file."""
    try:
        return np.loadtxt(path, ndmin=2)
    except (OSError, ValueError) as exc:
        raise UsageError('%s: cannot read %s (%s)' % (path, what, _one_line(exc)))


def load_frame_times(path):
    """Frame stamps from a text file (one per line) or a dataset .npz (time_stamps or t)."""
    if path.endswith('.npz'):
        try:
            with np.load(path) as data:
                key = next((k for k in ('time_stamps', 't') if k in data.files), None)
                if key is None:
                    raise UsageError('%s: no time_stamps or t array' % path)
                return np.asarray(data[key], float).ravel()
        except (OSError, ValueError) as exc:
            raise UsageError('%s: cannot read frame times (%s)' % (path, _one_line(exc)))
    return load_text_matrix(path, 'frame times').ravel()


def load_cam_T_imu(path):
    values = load_text_matrix(path, 'cam_T_imu').ravel()
    if values.size not in (12, 16):
        raise UsageError('%s: cam_T_imu needs 12 or 16 numbers, got %d' % (path, values.size))
    cam_T_imu = np.eye(4)
    cam_T_imu[:3, :] = values[:12].reshape(3, 4)
    return cam_T_imu


def frame_times_and_cam_T_imu(args):
    """What a KITTI poses file needs, from --dataset or --frame-times and --cam-T-imu."""
    if args.dataset:
        try:
            data = dataset.load_dataset(args.dataset, fix_twist_axes=False)
        except dataset.DatasetError as exc:
            raise UsageError(_one_line(exc))
        return data.t, data.cam_T_imu
    frame_times = load_frame_times(args.frame_times) if args.frame_times else None
    cam_T_imu = load_cam_T_imu(args.cam_T_imu) if args.cam_T_imu else None
    return frame_times, cam_T_imu


def load_groundtruth(args):
    frame_times, cam_T_imu = frame_times_and_cam_T_imu(args)
    try:
        return trajectory.read_groundtruth(args.groundtruth, frame_times, cam_T_imu)
    except trajectory.TrajectoryError as exc:
        raise UsageError(_one_line(exc))
    except (OSError, ValueError) as exc:
        raise UsageError('%s: cannot read ground truth (%s)' % (args.groundtruth, _one_line(exc)))


def load_estimate(path):
    try:
        return trajectory.read_tum(path)
    except trajectory.TrajectoryError as exc:
        raise UsageError(_one_line(exc))


def evaluate_consistency(path, t_est, estworld_T_imu, t_gt, gtworld_T_imu, max_dt):
    """NEES against ground truth when trajectory_covariance.txt lies beside the trajectory:
    (the summary for metrics.json, the per-pose series), or ({}, None) without it."""
    covariance_path = os.path.join(os.path.dirname(os.path.abspath(path)),
                                   'trajectory_covariance.txt')
    if not os.path.exists(covariance_path):
        return {}, None
    try:
        t_cov, covariances = metrics.read_trajectory_covariance(covariance_path)
        series = metrics.consistency_series(t_est, estworld_T_imu, t_cov, covariances, t_gt,
                                            gtworld_T_imu, max_dt)
        result = metrics.consistency_summary(series)
    except metrics.EvaluationError as exc:
        raise UsageError(_one_line(exc))
    result['covariance_file'] = covariance_path
    return result, series


def consistency_file_stems(labels):
    """consistency_LABEL per label, its characters outside [A-Za-z0-9_.-] replaced by '_' (a
    suffix -2, -3, ... where two labels come out alike)."""
    stems, used = {}, set()
    for label in labels:
        base = 'consistency_' + re.sub(r'[^A-Za-z0-9_.-]', '_', label)
        stem, n = base, 2
        while stem in used:
            stem, n = '%s-%d' % (base, n), n + 1
        used.add(stem)
        stems[label] = stem
    return stems


def evaluate_landmarks(args, gtworld_T_estworld, gauge_gtworld_T_estworld):
    """-> (metrics dict or None, aligned landmark positions (M, 3) in the ground-truth world).
    Errors after the trajectory's alignment; the consistency figures in the estimator's gauge
    (its first pose on the ground truth's, as the pose NEES)."""
    try:
        est_ids, estworld_xyz, est_sigma = metrics.read_landmarks_csv(args.landmarks)
        gtworld_xyz_aligned = metrics.transform_points(gtworld_T_estworld, estworld_xyz)
        if not args.landmarks_gt:
            return None, gtworld_xyz_aligned
        gt_ids, gtworld_xyz, _ = metrics.read_landmarks_csv(args.landmarks_gt)
    except metrics.EvaluationError as exc:
        raise UsageError(_one_line(exc))
    result = metrics.landmark_errors(est_ids, estworld_xyz, gt_ids, gtworld_xyz,
                                     gtworld_T_estworld, est_sigma, gauge_gtworld_T_estworld)
    for array_key in ('errors', 'matched_rows'):
        del result[array_key]
    result['landmarks_file'] = args.landmarks
    result['landmarks_gt_file'] = args.landmarks_gt
    result['landmark_within_3sigma_test'] = (
        'squared Mahalanobis error (diagonal covariance of the per-axis sigmas) <= %.2f '
        '(chi-square 3 dof at 0.9973), the estimator\'s first pose on the ground truth\'s'
        % metrics.CHI2_3DOF_3SIGMA)
    return result, gtworld_xyz_aligned


def json_ready(value):
    """Replace NaN/inf by None and numpy scalars by Python numbers, recursively."""
    if isinstance(value, dict):
        return {k: json_ready(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_ready(v) for v in value]
    if isinstance(value, (np.floating, float)):
        return float(value) if math.isfinite(value) else None
    if isinstance(value, np.integer):
        return int(value)
    return value


def _fmt(value, spec):
    return '-' if value is None or (isinstance(value, float) and not math.isfinite(value)) \
        else format(value, spec)


def format_table(results):
    """Compact text table, one row per estimate."""
    width = max([len('estimate')] + [len(label) for label in results])
    header = '%-*s %10s %12s %8s %11s %8s %9s %9s %9s' % (
        width, 'estimate', 'ATE RMSE m', 'rot RMSE deg', 'RPE %', 'final err m', 'matched',
        'NEES pos', 'in 95%', 'NEES pose')
    lines = [header, '-' * len(header)]
    for label, r in results.items():
        position = r.get('nees_position', {})
        pose = r.get('nees_pose', {})
        lines.append('%-*s %10s %12s %8s %11s %8d %9s %9s %9s' % (
            width, label, _fmt(r['ate_rmse_m'], '.3f'), _fmt(r['rotation_rmse_deg'], '.3f'),
            _fmt(r['rpe_percent'], '.3f'), _fmt(r['final_position_error_m'], '.3f'),
            r['matched_poses'], _fmt(position.get('mean'), '.2f'),
            _fmt(position.get('inside_95'), '.3f'), _fmt(pose.get('mean'), '.2f')))
    return '\n'.join(lines)


def run(args):
    t_gt, gtworld_T_imu = load_groundtruth(args)
    loaded = [(est, load_estimate(est['path'])) for est in args.estimates]
    try:
        os.makedirs(args.out, exist_ok=True)
    except OSError as exc:
        raise UsageError('%s: cannot create output directory (%s)' % (args.out, exc.strerror))

    results, matched, consistency = {}, {}, {}
    for est, (t_est, estworld_T_imu) in loaded:
        try:
            m = metrics.match_and_align(t_est, estworld_T_imu, t_gt, gtworld_T_imu, args.max_dt)
        except metrics.EvaluationError as exc:
            raise UsageError('%s: %s' % (est['path'], _one_line(exc)))
        matched[est['label']] = m
        results[est['label']] = dict(estimate=est['path'], **metrics.trajectory_metrics(m))
        summary, series = evaluate_consistency(est['path'], t_est, estworld_T_imu, t_gt,
                                               gtworld_T_imu, args.max_dt)
        results[est['label']].update(summary)
        if series is not None:
            consistency[est['label']] = series

    primary = args.estimates[0]['label']
    landmarks_xyz = None
    if args.landmarks:
        m = matched[primary]
        lm_result, landmarks_xyz = evaluate_landmarks(args, m.gtworld_T_estworld,
                                                      metrics.estimator_gauge(m))
        if lm_result is not None:
            results[primary].update(lm_result)

    report = dict(estimates=results, groundtruth=args.groundtruth, primary=primary,
                  max_dt_s=args.max_dt)
    try:
        with open(os.path.join(args.out, 'metrics.json'), 'w') as f:
            json.dump(json_ready(report), f, indent=2, allow_nan=False)
        write_plots(args, t_gt, gtworld_T_imu, matched, results, landmarks_xyz)
        stems = consistency_file_stems(consistency)
        for label, series in consistency.items():
            stem = os.path.join(args.out, stems[label])
            metrics.write_consistency_csv(stem + '.csv', series)
            plots.plot_consistency(stem + '.png', label, series, results[label],
                                   metrics.CHI2_95)
    except OSError as exc:
        raise UsageError('%s: cannot write (%s)' % (exc.filename or args.out, exc.strerror or exc))
    print_summary(results, primary, args.out)


def write_plots(args, t_gt, gtworld_T_imu, matched, results, landmarks_xyz):
    """The PNG figures of the evaluation (the first of ``matched`` is the primary estimate)."""
    primary = next(iter(matched))
    gt_sorted = gtworld_T_imu[np.argsort(t_gt, kind='stable')]
    gt_xyz = gt_sorted[:, :3, 3]
    axes = (plots.topdown_axes(gt_sorted[:, :3, :3]) if args.topdown_axes == 'auto'
            else plots.parse_axes(args.topdown_axes))
    m = matched[primary]
    plots.plot_topdown(os.path.join(args.out, 'trajectory_topdown.png'), gt_xyz,
                       m.gtworld_T_imu_est[:, :3, 3], landmarks_xyz, primary,
                       results[primary]['ate_rmse_m'], axes)
    plots.plot_error_along_path(os.path.join(args.out, 'error_along_path.png'),
                                [(label, mm.distance_m, mm.position_errors_m)
                                 for label, mm in matched.items()])
    if len(matched) > 1:
        plots.plot_comparison(os.path.join(args.out, 'comparison.png'), gt_xyz,
                              [(label, mm.gtworld_T_imu_est[:, :3, 3], results[label]['ate_rmse_m'])
                               for label, mm in matched.items()], axes)


def print_summary(results, primary, out_dir):
    """The table, the primary's landmark line and RPE notes, on stdout."""
    print(format_table(results))
    lm = results[primary]
    if 'landmarks_matched' in lm:
        print('landmarks (%s): %d of %d matched, RMSE %s m, median %s m, within 3 sigma %s, '
              'NEES %s (3 is consistent)'
              % (primary, lm['landmarks_matched'], lm['landmarks_estimated'],
                 _fmt(lm['landmark_rmse_m'], '.3f'), _fmt(lm['landmark_median_m'], '.3f'),
                 _fmt(lm['landmark_within_3sigma'], '.3f'), _fmt(lm['landmark_nees'], '.2f')))
        if lm.get('landmark_error_over_sigma_rms'):
            print('landmark error / sigma RMS (%s): %s' % (primary, ' '.join(
                '%s %.2f' % item for item in lm['landmark_error_over_sigma_rms'].items())))
    for label, r in results.items():
        axes = r.get('error_over_sigma_rms')
        if axes:
            print('error / sigma RMS (%s; 1 = the covariance is right about that axis): %s'
                  % (label, ' '.join('%s %.2f' % (name, axes[name]) for name in metrics.POSE_AXES)))
    for label, r in results.items():
        if r['rpe_note']:
            print('note (%s): RPE not computed: %s' % (label, r['rpe_note']))
    print('wrote %s' % os.path.join(out_dir, 'metrics.json'))


def main(argv=None):
    args = parse_args(sys.argv[1:] if argv is None else argv)
    # An empty file is reported as an error of its own; numpy's warning would only add noise.
    warnings.filterwarnings('ignore', message='loadtxt: input contained no data')
    try:
        run(args)
    except UsageError as exc:
        sys.stderr.write('%s: error: %s\n' % (PROG, exc))
        return 2
    return 0


if __name__ == '__main__':
    sys.exit(main())
