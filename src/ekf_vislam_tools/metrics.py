"""Trajectory and map accuracy metrics (pure numpy): association, Umeyama alignment, ATE, RPE.

Frames: the ground truth is ``gtworld_T_imu`` (poses of the IMU in the ground-truth world), the
estimate is ``estworld_T_imu`` (in the estimator's own world frame). The two worlds differ by an
unknown rigid motion ``gtworld_T_estworld``, found by a Umeyama fit (no scale) of the matched
estimated positions onto the ground-truth positions. Absolute errors (ATE, final position error,
landmark errors) are measured after applying it. The rotation RMSE is measured after the rotation
that best maps the estimated orientations onto the ground-truth ones instead: positions along a
nearly straight path leave the position fit's rotation about that path undetermined, and would
put an arbitrary roll into every orientation. The KITTI relative error (RPE) needs no alignment.

Typical use::

    matched = match_and_align(t_est, estworld_T_imu, t_gt, gtworld_T_imu, max_dt=0.02)
    result = trajectory_metrics(matched)          # JSON-ready dict
    # or in one step: evaluate_trajectory(t_est, estworld_T_imu, t_gt, gtworld_T_imu)
"""
import collections
import warnings

import numpy as np

#: Segment lengths (m) of the KITTI odometry benchmark.
KITTI_LENGTHS = (100.0, 200.0, 300.0, 400.0, 500.0, 600.0, 700.0, 800.0)

#: Chi-square quantile for 3 dof at probability 0.99730 (the mass within +-3 sigma in 1-D):
#: a landmark is "within 3 sigma" when its squared Mahalanobis error is <= this.
CHI2_3DOF_3SIGMA = 14.156413609126675


class EvaluationError(ValueError):
    """Inputs that cannot be evaluated (too few matches, inconsistent shapes, bad files)."""


# ---------------------------------------------------------------------------------------------
# Association and alignment
# ---------------------------------------------------------------------------------------------

def associate(t_est, t_gt, max_dt=0.02):
    """Match each estimate stamp to the nearest ground-truth stamp within ``max_dt`` seconds.

    Matching is one-to-one: when several estimate stamps pick the same ground-truth stamp, only
    the closest one is kept. Unmatched poses on either side are ignored.

    Returns ``(idx_est, idx_gt)``, integer arrays of equal length, ordered by ground-truth time.
    """
    t_est = np.asarray(t_est, dtype=float).ravel()
    t_gt = np.asarray(t_gt, dtype=float).ravel()
    empty = np.zeros(0, dtype=int)
    if t_est.size == 0 or t_gt.size == 0:
        return empty, empty.copy()
    gt_order = np.argsort(t_gt, kind='stable')
    t_gt_sorted = t_gt[gt_order]
    right = np.clip(np.searchsorted(t_gt_sorted, t_est), 1, t_gt_sorted.size - 1)
    left = right - 1
    if t_gt_sorted.size == 1:
        left = right = np.zeros_like(right)
    use_left = np.abs(t_est - t_gt_sorted[left]) <= np.abs(t_gt_sorted[right] - t_est)
    nearest = np.where(use_left, left, right)
    dt = np.abs(t_gt_sorted[nearest] - t_est)
    idx_est = np.flatnonzero(dt <= max_dt)
    if idx_est.size == 0:
        return empty, empty.copy()
    nearest, dt = nearest[idx_est], dt[idx_est]
    # One-to-one: per ground-truth stamp keep the estimate with the smallest |dt|.
    order = np.lexsort((dt, nearest))
    keep = order[np.r_[True, nearest[order][1:] != nearest[order][:-1]]]
    keep = keep[np.argsort(nearest[keep], kind='stable')]
    return idx_est[keep], gt_order[nearest[keep]]


def umeyama_alignment(src_xyz, dst_xyz, with_scale=False):
    """Least-squares similarity (Umeyama 1991) with ``dst ~= s * R @ src + t``.

    ``src_xyz``, ``dst_xyz``: (N, 3) corresponding points, N >= 3 (not all collinear for a
    unique rotation). Returns ``(R, t, s)`` with R a proper rotation (det +1) and s = 1 unless
    ``with_scale``.
    """
    src = np.asarray(src_xyz, dtype=float)
    dst = np.asarray(dst_xyz, dtype=float)
    if src.shape != dst.shape or src.ndim != 2 or src.shape[1] != 3:
        raise EvaluationError('umeyama_alignment: need two (N, 3) arrays of equal shape, '
                              'got %s and %s' % (src.shape, dst.shape))
    if src.shape[0] < 3:
        raise EvaluationError('umeyama_alignment: need at least 3 points, got %d' % src.shape[0])
    mu_src, mu_dst = src.mean(axis=0), dst.mean(axis=0)
    src_c, dst_c = src - mu_src, dst - mu_dst
    cov = dst_c.T @ src_c / src.shape[0]
    U, D, Vt = np.linalg.svd(cov)
    S = np.eye(3)
    if np.linalg.det(U) * np.linalg.det(Vt) < 0:
        S[2, 2] = -1.0
    R = U @ S @ Vt
    s = 1.0
    if with_scale:
        var_src = np.mean(np.sum(src_c ** 2, axis=1))
        s = float(np.trace(np.diag(D) @ S) / var_src) if var_src > 0 else 1.0
    t = mu_dst - s * R @ mu_src
    return R, t, s


def transform_from(R, t):
    """(3x3, 3) -> 4x4 homogeneous transform."""
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = t
    return T


def transform_points(b_T_a, xyz_a):
    """(N, 3) points in frame a -> frame b, with the 4x4 rigid transform b_T_a."""
    b_T_a = np.asarray(b_T_a, dtype=float)
    return np.asarray(xyz_a, dtype=float) @ b_T_a[:3, :3].T + b_T_a[:3, 3]


# ---------------------------------------------------------------------------------------------
# Error measures
# ---------------------------------------------------------------------------------------------

def rotation_angles(R):
    """Rotation angle(s) in radians of (..., 3, 3) rotation matrices, accurate near 0 and pi."""
    R = np.asarray(R, dtype=float)
    cos_theta = 0.5 * (np.trace(R, axis1=-2, axis2=-1) - 1.0)
    vee = np.stack([R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0],
                    R[..., 1, 0] - R[..., 0, 1]], axis=-1)
    sin_theta = 0.5 * np.linalg.norm(vee, axis=-1)
    return np.arctan2(sin_theta, cos_theta)


def error_stats(errors):
    """Summary of non-negative errors -> dict(rmse, mean, median, max); NaN when empty."""
    e = np.asarray(errors, dtype=float)
    if e.size == 0:
        return dict(rmse=np.nan, mean=np.nan, median=np.nan, max=np.nan)
    return dict(rmse=float(np.sqrt(np.mean(e ** 2))), mean=float(np.mean(e)),
                median=float(np.median(e)), max=float(np.max(e)))


def ate(gt_xyz, est_xyz, align=True):
    """Absolute trajectory error of matched positions.

    ``gt_xyz``, ``est_xyz``: (N, 3) positions of the same instants (ground-truth world and
    estimator world). With ``align`` the estimate is first moved by the rigid Umeyama fit
    (no scale); otherwise it is taken as already expressed in the ground-truth world.

    Returns dict(rmse, mean, median, max, errors[N], R, t) where (R, t) is the alignment
    ``gtworld_T_estworld`` that was applied (identity without ``align``).
    """
    gt_xyz = np.asarray(gt_xyz, dtype=float)
    est_xyz = np.asarray(est_xyz, dtype=float)
    if align:
        R, t, _ = umeyama_alignment(est_xyz, gt_xyz)
    else:
        R, t = np.eye(3), np.zeros(3)
    errors = np.linalg.norm(transform_points(transform_from(R, t), est_xyz) - gt_xyz, axis=1)
    result = error_stats(errors)
    result.update(errors=errors, R=R, t=t)
    return result


def orientation_alignment(R_gt, R_est):
    """The rotation R (3, 3) that best maps the estimated orientations onto the ground truth's:
    the minimiser of sum_k |R_gt[k] - R R_est[k]|_F^2 over matched (N, 3, 3) rotations, the
    projection of sum_k R_gt[k] R_est[k]^T onto SO(3)."""
    M = np.einsum('nij,nkj->ik', np.asarray(R_gt, dtype=float), np.asarray(R_est, dtype=float))
    U, _, Vt = np.linalg.svd(M)
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt))])
    return U @ D @ Vt


def rotation_rmse(R_gt, R_est, R_align=None):
    """RMSE (degrees) of the angle of ``R_gt^T (R_align R_est)`` over matched (N, 3, 3) rotations.

    ``R_align`` is the rotation of ``gtworld_T_estworld`` (identity when omitted).
    """
    R_gt = np.asarray(R_gt, dtype=float)
    R_est = np.asarray(R_est, dtype=float)
    if R_align is not None:
        R_est = np.einsum('ij,njk->nik', R_align, R_est)
    angles = rotation_angles(np.einsum('nji,njk->nik', R_gt, R_est))
    return float(np.degrees(np.sqrt(np.mean(angles ** 2)))) if angles.size else float('nan')


def path_distances(xyz):
    """Cumulative distance travelled (m) along (N, 3) positions; starts at 0."""
    xyz = np.asarray(xyz, dtype=float)
    if xyz.shape[0] == 0:
        return np.zeros(0)
    return np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(xyz, axis=0), axis=1))])


def _inverse_rigid(T):
    """Inverse of (N, 4, 4) rigid transforms."""
    Ti = np.tile(np.eye(4), (T.shape[0], 1, 1))
    Ti[:, :3, :3] = np.transpose(T[:, :3, :3], (0, 2, 1))
    Ti[:, :3, 3] = -np.einsum('nji,nj->ni', T[:, :3, :3], T[:, :3, 3])
    return Ti


def _relative_poses(T, first, last):
    """inv(T[first]) @ T[last] for index arrays of (N, 4, 4) rigid transforms."""
    return np.einsum('nij,njk->nik', _inverse_rigid(T[first]), T[last])


def rpe_kitti(T_gt, T_est, lengths=KITTI_LENGTHS, step=10):
    """KITTI odometry relative error of matched pose sequences (no alignment needed).

    ``T_gt``, ``T_est``: (N, 4, 4) poses of the same instants (``world_T_imu`` in their own
    worlds). For every start frame ``s`` in ``0, step, 2*step, ...`` and every segment length L,
    the end frame ``e`` is the first one whose ground-truth path distance from ``s`` is >= L.
    The segment error is ``E = inv(inv(GT_s) GT_e) @ (inv(Est_s) Est_e)``; its translation norm
    divided by L is the translation error, its rotation angle divided by L the rotation error.
    Errors are averaged over all (start, length) pairs, as in the KITTI devkit.

    Returns a dict:
      ``rpe_percent``: mean translation error in % (None when there is no segment),
      ``rpe_rot_deg_per_100m``: mean rotation error in deg per 100 m (None likewise),
      ``rpe_segments``: number of segments,
      ``rpe_by_length``: {str(int(L)): {trans_percent, rot_deg_per_100m, segments}},
      ``rpe_note``: why the metric is null, or None.
    """
    T_gt = np.asarray(T_gt, dtype=float)
    T_est = np.asarray(T_est, dtype=float)
    if T_gt.shape != T_est.shape or T_gt.ndim != 3 or T_gt.shape[1:] != (4, 4):
        raise EvaluationError('rpe_kitti: need two (N, 4, 4) arrays of equal shape, got %s and %s'
                              % (T_gt.shape, T_est.shape))
    dist = path_distances(T_gt[:, :3, 3])
    starts = np.arange(0, T_gt.shape[0], int(step))
    trans_err, rot_err, by_length = [], [], {}
    for length in lengths:
        ends = np.searchsorted(dist, dist[starts] + length, side='left')
        valid = ends < T_gt.shape[0]
        first, last = starts[valid], ends[valid]
        delta_gt = _relative_poses(T_gt, first, last)
        delta_est = _relative_poses(T_est, first, last)
        error = np.einsum('nij,njk->nik', _inverse_rigid(delta_gt), delta_est)
        t_e = np.linalg.norm(error[:, :3, 3], axis=1) / length
        r_e = rotation_angles(error[:, :3, :3]) / length
        trans_err.append(t_e)
        rot_err.append(r_e)
        by_length[str(int(round(length)))] = dict(
            trans_percent=float(100.0 * t_e.mean()) if t_e.size else None,
            rot_deg_per_100m=float(np.degrees(r_e.mean()) * 100.0) if r_e.size else None,
            segments=int(t_e.size))
    trans_err, rot_err = np.concatenate(trans_err), np.concatenate(rot_err)
    note = None
    if trans_err.size == 0:
        note = ('ground-truth path of the matched poses is %.1f m, shorter than the shortest '
                'segment (%g m)' % (dist[-1] if dist.size else 0.0, min(lengths)))
    return dict(
        rpe_percent=float(100.0 * trans_err.mean()) if trans_err.size else None,
        rpe_rot_deg_per_100m=float(np.degrees(rot_err.mean()) * 100.0) if rot_err.size else None,
        rpe_segments=int(trans_err.size),
        rpe_by_length=by_length,
        rpe_note=note)


# ---------------------------------------------------------------------------------------------
# Whole-trajectory evaluation
# ---------------------------------------------------------------------------------------------

#: A matched and aligned trajectory (all arrays over the N matched poses, in ground-truth order):
#:   idx_est, idx_gt      indices into the estimate / ground-truth inputs;
#:   t                    ground-truth stamps of the matches;
#:   gtworld_T_imu_gt     ground-truth poses;
#:   gtworld_T_imu_est    estimated poses moved into the ground-truth world by the alignment;
#:   estworld_T_imu_est   estimated poses as given;
#:   gtworld_T_estworld   4x4 rigid alignment (Umeyama, no scale);
#:   position_errors_m    |p_est_aligned - p_gt|;
#:   distance_m           ground-truth distance travelled, measured along the full ground truth
#:                        from its first pose, at each match.
AlignedTrajectory = collections.namedtuple('AlignedTrajectory', [
    'idx_est', 'idx_gt', 't', 'gtworld_T_imu_gt', 'gtworld_T_imu_est', 'estworld_T_imu_est',
    'gtworld_T_estworld', 'position_errors_m', 'distance_m'])


def match_and_align(t_est, estworld_T_imu, t_gt, gtworld_T_imu, max_dt=0.02):
    """Associate by time stamp and align the estimate onto the ground truth.

    Raises EvaluationError with a one-line explanation when fewer than 3 poses match.
    """
    t_est = np.asarray(t_est, dtype=float)
    t_gt = np.asarray(t_gt, dtype=float)
    estworld_T_imu = np.asarray(estworld_T_imu, dtype=float)
    gtworld_T_imu = np.asarray(gtworld_T_imu, dtype=float)
    for name, t, T in (('estimate', t_est, estworld_T_imu), ('ground truth', t_gt, gtworld_T_imu)):
        if T.ndim != 3 or T.shape[1:] != (4, 4) or T.shape[0] != t.shape[0]:
            raise EvaluationError('%s: need N stamps and (N, 4, 4) poses, got %s and %s'
                                  % (name, t.shape, T.shape))
    idx_est, idx_gt = associate(t_est, t_gt, max_dt)
    if idx_est.size < 3:
        raise EvaluationError(
            'only %d of %d estimate poses have a ground-truth stamp within %g s (need 3); estimate '
            't in [%s], ground truth t in [%s]'
            % (idx_est.size, t_est.size, max_dt, _span(t_est), _span(t_gt)))
    gt = gtworld_T_imu[idx_gt]
    est = estworld_T_imu[idx_est]
    result = ate(gt[:, :3, 3], est[:, :3, 3], align=True)
    gtworld_T_estworld = transform_from(result['R'], result['t'])
    gt_order = np.argsort(t_gt, kind='stable')
    distance_full = np.empty(t_gt.size)
    distance_full[gt_order] = path_distances(gtworld_T_imu[gt_order, :3, 3])
    return AlignedTrajectory(
        idx_est=idx_est, idx_gt=idx_gt, t=t_gt[idx_gt], gtworld_T_imu_gt=gt,
        gtworld_T_imu_est=np.einsum('ij,njk->nik', gtworld_T_estworld, est),
        estworld_T_imu_est=est, gtworld_T_estworld=gtworld_T_estworld,
        position_errors_m=result['errors'], distance_m=distance_full[idx_gt])


def estimator_gauge(matched):
    """gtworld_T_estworld that puts the estimate's first matched pose on the ground truth's: the
    frame in which the estimator's covariances hold (its first pose is exact), for an
    AlignedTrajectory."""
    return matched.gtworld_T_imu_gt[0] @ _inverse_rigid(matched.estworld_T_imu_est[:1])[0]


def _span(t):
    return '%.3f, %.3f' % (t.min(), t.max()) if t.size else 'empty'


def trajectory_metrics(matched, lengths=KITTI_LENGTHS, step=10):
    """JSON-ready metrics of an AlignedTrajectory (see the module docstring for the frames).

    Keys: ate_rmse_m, ate_mean_m, ate_median_m, ate_max_m, rotation_rmse_deg,
    final_position_error_m, path_length_m (ground truth between the first and last match),
    matched_poses, gtworld_T_estworld (4x4 list) and the keys of :func:`rpe_kitti`.
    """
    stats = error_stats(matched.position_errors_m)
    result = dict(
        ate_rmse_m=stats['rmse'], ate_mean_m=stats['mean'], ate_median_m=stats['median'],
        ate_max_m=stats['max'],
        rotation_rmse_deg=rotation_rmse(
            matched.gtworld_T_imu_gt[:, :3, :3], matched.estworld_T_imu_est[:, :3, :3],
            orientation_alignment(matched.gtworld_T_imu_gt[:, :3, :3],
                                  matched.estworld_T_imu_est[:, :3, :3])),
        final_position_error_m=float(matched.position_errors_m[-1]),
        path_length_m=float(matched.distance_m[-1] - matched.distance_m[0]),
        matched_poses=int(matched.idx_est.size),
        gtworld_T_estworld=matched.gtworld_T_estworld.tolist())
    result.update(rpe_kitti(matched.gtworld_T_imu_gt, matched.estworld_T_imu_est, lengths, step))
    return result


def evaluate_trajectory(t_est, T_est, t_gt, T_gt, max_dt=0.02, lengths=KITTI_LENGTHS, step=10):
    """All trajectory metrics in one call: ``T_est`` = estworld_T_imu, ``T_gt`` = gtworld_T_imu.

    Equivalent to ``trajectory_metrics(match_and_align(...))``; returns the same dict.
    """
    return trajectory_metrics(match_and_align(t_est, T_est, t_gt, T_gt, max_dt), lengths, step)


# ---------------------------------------------------------------------------------------------
# Landmarks
# ---------------------------------------------------------------------------------------------

def read_landmarks_csv(path, require_sigma=False):
    """Read a landmark CSV with a header naming its columns.

    Needs columns id, x, y, z; sigma_x, sigma_y, sigma_z are returned when present (required
    with ``require_sigma``); other columns (e.g. observations) are ignored.
    Returns ``(ids[N] int, xyz[N, 3], sigma[N, 3] or None)``; raises EvaluationError naming the
    file on any problem.
    """
    try:
        with open(path) as f:
            header = f.readline()
    except (OSError, ValueError) as exc:
        raise EvaluationError('%s: cannot read landmark CSV (%s)' % (path, exc))
    columns = [c.strip().lower() for c in header.strip().split(',')]
    needed = ['id', 'x', 'y', 'z'] + (['sigma_x', 'sigma_y', 'sigma_z'] if require_sigma else [])
    missing = [c for c in needed if c not in columns]
    if missing:
        raise EvaluationError('%s: landmark CSV header lacks column(s) %s (first line: %.60s)'
                              % (path, ', '.join(missing), header.strip()))
    try:
        with warnings.catch_warnings():
            warnings.simplefilter('ignore', UserWarning)  # "input contained no data"
            data = np.loadtxt(path, delimiter=',', skiprows=1, ndmin=2)
    except (OSError, ValueError) as exc:
        raise EvaluationError('%s: cannot read landmark CSV (%s)' % (path, exc))
    if data.size == 0:
        data = np.zeros((0, len(columns)))
    if data.shape[1] != len(columns):
        raise EvaluationError('%s: %d columns in the header but %d in the rows'
                              % (path, len(columns), data.shape[1]))
    col = {name: i for i, name in enumerate(columns)}
    xyz = data[:, [col['x'], col['y'], col['z']]]
    if not np.all(np.isfinite(xyz)):
        raise EvaluationError('%s: non-finite landmark coordinates' % path)
    ids = data[:, col['id']]
    if not np.all(ids == np.round(ids)):
        raise EvaluationError('%s: landmark ids must be integers' % path)
    sigma = None
    if all(c in col for c in ('sigma_x', 'sigma_y', 'sigma_z')):
        sigma = data[:, [col['sigma_x'], col['sigma_y'], col['sigma_z']]]
    return ids.astype(np.int64), xyz, sigma


def landmark_errors(est_ids, estworld_xyz, gt_ids, gtworld_xyz, gtworld_T_estworld=None,
                    est_sigma=None, gauge_gtworld_T_estworld=None):
    """Errors of estimated landmarks against ground truth, matched by id.

    ``estworld_xyz`` (N, 3) are in the estimator's world; they are moved by the trajectory
    alignment ``gtworld_T_estworld`` (4x4, identity when None) before comparison with
    ``gtworld_xyz`` (M, 3). Every estimate row whose id exists in the ground truth is compared
    (an id repeated in the estimate is compared once per row); a ground-truth id listed twice
    uses its first row.

    ``est_sigma`` (N, 3): per-axis standard deviations in the estimator's world, taken as a
    diagonal covariance. A landmark is within 3 sigma when its squared Mahalanobis error (the
    error rotated back into the estimator's world) is <= CHI2_3DOF_3SIGMA (14.16, the 3-dof
    quantile at the 1-D 3-sigma probability 0.9973). Rows with non-positive or non-finite sigmas
    are left out of that fraction. The same errors give the landmark NEES (the mean of that
    squared Mahalanobis error: 3 when the sigmas are right, whatever the axes' correlation, which
    a diagonal leaves out) and the RMS of error / sigma per axis (1 when right).

    ``gauge_gtworld_T_estworld``: the ground truth's world from the estimator's as the estimator
    defines it (its first pose is exact), for those consistency figures; the trajectory's
    alignment would take out part of the drift that the landmarks' sigmas carry. When None,
    ``gtworld_T_estworld`` serves.

    Returns a dict: landmark_rmse_m, landmark_mean_m, landmark_median_m, landmark_max_m,
    landmarks_matched, landmarks_estimated, landmark_within_3sigma (fraction or None),
    landmark_nees (mean, or None), landmark_error_over_sigma_rms ({x, y, z} or None),
    landmarks_with_sigma, errors (array over matched rows), matched_rows (indices into est).
    """
    est_ids = np.asarray(est_ids).ravel()
    gt_ids = np.asarray(gt_ids).ravel()
    estworld_xyz = np.asarray(estworld_xyz, dtype=float).reshape(-1, 3)
    gtworld_xyz = np.asarray(gtworld_xyz, dtype=float).reshape(-1, 3)
    if gtworld_T_estworld is None:
        gtworld_T_estworld = np.eye(4)

    gt_unique, gt_first = np.unique(gt_ids, return_index=True)
    pos = np.clip(np.searchsorted(gt_unique, est_ids), 0, max(gt_unique.size - 1, 0))
    found = gt_unique.size > 0
    rows = np.flatnonzero(gt_unique[pos] == est_ids) if found else np.zeros(0, dtype=int)
    gt_rows = gt_first[pos[rows]]
    error_gtworld = transform_points(gtworld_T_estworld, estworld_xyz[rows]) - gtworld_xyz[gt_rows]
    errors = np.linalg.norm(error_gtworld, axis=1)
    stats = error_stats(errors)

    within, landmark_nees, per_axis, n_sigma = None, None, None, 0
    if est_sigma is not None and rows.size:
        sigma = np.asarray(est_sigma, dtype=float).reshape(-1, 3)[rows]
        valid = np.all(np.isfinite(sigma) & (sigma > 0), axis=1)
        n_sigma = int(valid.sum())
        if n_sigma:
            gauge = (gtworld_T_estworld if gauge_gtworld_T_estworld is None
                     else gauge_gtworld_T_estworld)
            # The error in the estimator's world (where sigma is diagonal), in the gauge.
            estworld_T_gtworld = _inverse_rigid(np.asarray(gauge, dtype=float)[None])[0]
            error_estworld = (transform_points(estworld_T_gtworld, gtworld_xyz[gt_rows[valid]])
                              - estworld_xyz[rows[valid]])
            normalized = error_estworld / sigma[valid]
            mahalanobis2 = np.sum(normalized ** 2, axis=1)
            within = float(np.mean(mahalanobis2 <= CHI2_3DOF_3SIGMA))
            landmark_nees = float(np.mean(mahalanobis2))
            per_axis = dict(zip('xyz', (float(v) for v in np.sqrt(np.mean(normalized ** 2, 0)))))
    return dict(
        landmark_rmse_m=stats['rmse'], landmark_mean_m=stats['mean'],
        landmark_median_m=stats['median'], landmark_max_m=stats['max'],
        landmarks_matched=int(rows.size), landmarks_estimated=int(est_ids.size),
        landmark_within_3sigma=within, landmark_nees=landmark_nees,
        landmark_error_over_sigma_rms=per_axis, landmarks_with_sigma=n_sigma,
        errors=errors, matched_rows=rows)


# ---------------------------------------------------------------------------------------------
# Consistency: NEES of the pose against ground truth
# ---------------------------------------------------------------------------------------------

#: chi-square 0.95 quantiles for 3 and 6 degrees of freedom.
CHI2_95 = {3: 7.814727903251178, 6: 12.591587243743977}


def read_trajectory_covariance(path):
    """-> (t[N], P[N,6,6]) of a trajectory_covariance.txt ("t" then 36 row-major entries)."""
    try:
        data = np.loadtxt(path, ndmin=2)
    except (OSError, ValueError) as exc:
        raise EvaluationError('%s: cannot read covariances (%s)' % (path, exc))
    if data.shape[0] == 0 or data.shape[1] != 37:
        raise EvaluationError('%s: expected 37 columns (t and a row-major 6x6), got %d'
                              % (path, data.shape[1] if data.size else 0))
    return data[:, 0].copy(), data[:, 1:].reshape(-1, 6, 6)


def so3_log(R):
    """Rotation vector of each rotation matrix (N,3,3) -> (N,3)."""
    R = np.asarray(R, dtype=float)
    cos = np.clip((np.trace(R, axis1=1, axis2=2) - 1.0) / 2.0, -1.0, 1.0)
    angle = np.arccos(cos)
    v = np.stack([R[:, 2, 1] - R[:, 1, 2], R[:, 0, 2] - R[:, 2, 0], R[:, 1, 0] - R[:, 0, 1]], 1)
    sin = np.sin(angle)
    scale = np.where(sin > 1e-9, angle / (2.0 * np.where(sin > 1e-9, sin, 1.0)), 0.5)
    return v * scale[:, None]


def pose_errors_in_estimator_gauge(estworld_T_imu, gtworld_T_imu):
    """World-axis pose errors [dp; dtheta] (N,6) of matched estimate and ground-truth poses, with
    the ground truth moved by one rigid transform so that its first pose equals the estimate's
    first pose (the estimator's world), and no other alignment. dp = p_est - p_true,
    dtheta = log(R_est R_true^T): the left (world-frame) perturbation world_T_imu =
    exp(eps^) world_T_imu_true that the estimator's pose covariance describes."""
    est = np.asarray(estworld_T_imu, dtype=float)
    gt = np.asarray(gtworld_T_imu, dtype=float)
    estworld_T_gtworld = est[0] @ _inverse_rigid(gt[0][None])[0]
    moved = np.einsum('ij,njk->nik', estworld_T_gtworld, gt)
    dp = est[:, :3, 3] - moved[:, :3, 3]
    dtheta = so3_log(np.einsum('nij,nkj->nik', est[:, :3, :3], moved[:, :3, :3]))
    return np.hstack([dp, dtheta])


def nees(errors, covariances):
    """Normalized estimation error squared e^T P^-1 e of each row (N,k) against (N,k,k)."""
    errors = np.asarray(errors, dtype=float)
    solved = np.linalg.solve(np.asarray(covariances, dtype=float), errors[:, :, None])[:, :, 0]
    return np.einsum('ni,ni->n', errors, solved)


def nees_stats(values, dof):
    values = np.asarray(values, dtype=float)
    return dict(mean=float(np.mean(values)), median=float(np.median(values)),
                inside_95=float(np.mean(values <= CHI2_95[dof])), dof=dof, poses=int(values.size))


#: Names of the pose error's axes, in the covariance's (ROS) order, world axes.
POSE_AXES = ('x', 'y', 'z', 'rot_x', 'rot_y', 'rot_z')


def normalized_error_rms(errors, covariances):
    """Per axis, the RMS over the rows of error / sigma (sigma: the square root of that axis's
    variance): 1 when the covariance is right about that axis, below 1 when it is too wide, above
    1 when too narrow. Errors (N,k), covariances (N,k,k)."""
    sigmas = np.sqrt(np.einsum('nii->ni', np.asarray(covariances, dtype=float)))
    return error_over_sigma_rms(errors, sigmas)


def error_over_sigma_rms(errors, sigmas):
    """Per axis, the RMS over the rows of error / sigma; errors and sigmas (N,k)."""
    return np.sqrt(np.mean((np.asarray(errors, dtype=float) / sigmas) ** 2, axis=0))


def consistency_series(t_est, estworld_T_imu, t_cov, covariances, t_gt, gtworld_T_imu,
                       max_dt=0.02):
    """Per pose with a covariance and ground truth (the first, which defines the gauge, left
    out): dict of t (N), position_nees (N), pose_nees (N), errors (N,6) and sigmas (N,6), world
    axes in :data:`POSE_AXES` order (the estimator's world, its first pose on the ground
    truth's)."""
    idx_cov, idx_cov_est = associate(t_cov, t_est, max_dt)
    if idx_cov.size < 3:
        raise EvaluationError('only %d covariances match an estimate pose' % idx_cov.size)
    est_t = np.asarray(t_est)[idx_cov_est]
    idx_est, idx_gt = associate(est_t, t_gt, max_dt)
    if idx_est.size < 3:
        raise EvaluationError('only %d poses with a covariance have ground truth' % idx_est.size)
    est = np.asarray(estworld_T_imu)[idx_cov_est][idx_est]
    P = np.asarray(covariances)[idx_cov][idx_est]
    # The first pose defines the gauge (its error is zero by construction): left out.
    errors = pose_errors_in_estimator_gauge(est, np.asarray(gtworld_T_imu)[idx_gt])[1:]
    P = P[1:]
    return dict(t=est_t[idx_est][1:], position_nees=nees(errors[:, :3], P[:, :3, :3]),
                pose_nees=nees(errors, P), errors=errors,
                sigmas=np.sqrt(np.einsum('nii->ni', P)))


def consistency(t_est, estworld_T_imu, t_cov, covariances, t_gt, gtworld_T_imu, max_dt=0.02):
    """Position (3 dof) and pose (6 dof) NEES of an estimate with its per-pose covariance, and
    per axis the RMS of error / sigma; the per-pose values are :func:`consistency_series`'s."""
    return consistency_summary(consistency_series(t_est, estworld_T_imu, t_cov, covariances,
                                                  t_gt, gtworld_T_imu, max_dt))


def consistency_summary(series):
    """:func:`consistency`'s figures from a :func:`consistency_series`."""
    per_axis = error_over_sigma_rms(series['errors'], series['sigmas'])
    return dict(nees_position=nees_stats(series['position_nees'], 3),
                nees_pose=nees_stats(series['pose_nees'], 6),
                error_over_sigma_rms=dict(zip(POSE_AXES, (float(v) for v in per_axis))))


def write_consistency_csv(path, series):
    """The per-pose values of :func:`consistency_series` as CSV, one row per pose."""
    header = ['t', 'position_nees', 'pose_nees']
    header += ['error_' + a for a in POSE_AXES] + ['sigma_' + a for a in POSE_AXES]
    rows = np.column_stack([series['t'], series['position_nees'], series['pose_nees'],
                            series['errors'], series['sigmas']])
    np.savetxt(path, rows, delimiter=',', header=','.join(header), comments='',
               fmt=['%.6f'] + ['%.9g'] * (rows.shape[1] - 1))
