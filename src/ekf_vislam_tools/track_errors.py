"""Error statistics of feature tracks against ground-truth poses (scripts/track_error_stats.py).

Each track (an id seen in consecutive frames) gets the landmark that best explains all of its
stereo observations from the ground-truth camera poses (Gauss-Newton, Huber weights); its
residuals are then the track's pixel errors (plus the ground truth's own pose error). From them:
the stationary std, the correlation from one frame to the next (lag 1, 2, 5, 10), the part
shared by all tracks of a frame, the std of the differenced error e_k - rho e_(k-1), the mean
drift per frame by image region (a systematic error no noise model averages away), the
random-walk rate of the error (its variogram over 1-3 frames: noise/track_random_walk), and how
unequal the tracks are (each track's RMS error and drift rate; the share of all squared error
that the worst tracks hold).
"""
import numpy as np

from ekf_vislam_tools import metrics, stereo_geometry, trajectory

INLIER_PX = 6.0       # residuals beyond this are outliers for the statistics
TRACK_MAX_PX = 20.0   # a track with a larger residual is dropped (wrong association)
MIN_TRACK = 4         # observations
LAGS = (1, 2, 5, 10)
RANDOM_WALK_LAGS = (1, 2, 3)  # frames: the lags the random-walk part is fitted over
PER_TRACK_MIN = 6     # inlier observations for a track's own RMS and drift rate
PERCENTILES = (10, 50, 90)


def camera_poses(data, groundtruth_path):
    """(T,4,4) cam_T_world per frame of a `dataset.Dataset` from ground truth (TUM world_T_imu
    matched by time stamp, or KITTI poses), NaN where the ground truth has no pose."""
    t_gt, world_T_imu = trajectory.read_groundtruth(groundtruth_path, data.t, data.cam_T_imu)
    index_data, index_gt = metrics.associate(data.t, t_gt, 0.02)
    if index_data.size < 2:
        raise ValueError('%s: fewer than 2 poses match the dataset\'s time stamps'
                         % groundtruth_path)
    cam_T_world = np.full((data.num_frames, 4, 4), np.nan)
    cam_T_world[index_data] = np.einsum('ij,njk->nik', data.cam_T_imu,
                                        np.linalg.inv(world_T_imu[index_gt]))
    return cam_T_world


def _project(cam_T_world, p_world, K, b):
    """(n,4) predicted [uL, vL, uR, vR], (n,4,3) Jacobians w.r.t. p_world and (n,) depths."""
    R, t = cam_T_world[:, :3, :3], cam_T_world[:, :3, 3]
    p_cam = np.einsum('nij,j->ni', R, p_world) + t
    z_pred, depth = stereo_geometry.project(p_cam, K, b)
    return z_pred, np.einsum('nij,njk->nik', stereo_geometry.project_jacobian(p_cam, K, b), R), depth


def _stereo_point(z, cam_T_world, K, b, i):
    """World point of observation i's own stereo triangulation."""
    p_cam = stereo_geometry.triangulate(z[i:i + 1], K, b)[0]
    world_T_cam = np.linalg.inv(cam_T_world[i])
    return world_T_cam[:3, :3] @ p_cam + world_T_cam[:3, 3]


def _gauss_newton(z, cam_T_world, K, b, p, iterations):
    """Huber-weighted Gauss-Newton on the stereo reprojection from p -> p, or None when a camera
    sees the point closer than 0.5 m or the iteration leaves the finite numbers."""
    for _ in range(iterations):
        z_pred, H, depth = _project(cam_T_world, p, K, b)
        if np.any(depth < 0.5):
            return None
        r = (z - z_pred).ravel()
        J = H.reshape(-1, 3)
        w = 1.0 / np.maximum(1.0, np.abs(r) / 3.0)  # Huber
        step = np.linalg.lstsq(J * w[:, None], r * w, rcond=None)[0]
        p = p + step
        if not np.all(np.isfinite(p)):
            return None
        if np.linalg.norm(step) < 1e-6:
            break
    return p


def fit_track(z, cam_T_world, K, b, iterations=8):
    """Landmark fitted to one track's observations z (n,4) -> residuals (n,4), or None when the
    track cannot be fitted (non-positive disparity, behind a camera, gross residuals)."""
    if z[0, 0] - z[0, 2] <= 0.5:
        return None
    p = _gauss_newton(z, cam_T_world, K, b, _stereo_point(z, cam_T_world, K, b, 0), iterations)
    if p is None:
        return None
    z_pred, _, depth = _project(cam_T_world, p, K, b)
    residual = z - z_pred
    if np.any(depth < 0.5) or np.max(np.abs(residual)) > TRACK_MAX_PX:
        return None
    return residual


def fit_landmark(z, cam_T_world, K, b, inlier_px=INLIER_PX, rounds=4, iterations=15):
    """The world point that best explains a track's observations z (n,4) from the cameras
    cam_T_world (n,4,4): Gauss-Newton from the first observation with a disparity above 0.5 px,
    then the observations with a residual over inlier_px (any coordinate) left out and the point
    fitted again, until the set holds (at most `rounds` fits). -> (p_world (3,), inliers (n,)
    bool), or None with fewer than 2 inliers, or a point that an inlier camera sees closer than
    0.5 m or at a disparity below 0.5 px (its depth not determined)."""
    inliers = np.ones(len(z), dtype=bool)
    for _ in range(rounds):
        start = np.flatnonzero(inliers & (z[:, 0] - z[:, 2] > 0.5))
        if inliers.sum() < 2 or start.size == 0:
            return None
        p = _gauss_newton(z[inliers], cam_T_world[inliers], K, b,
                          _stereo_point(z, cam_T_world, K, b, start[0]), iterations)
        if p is None:
            return None
        z_pred, _, depth = _project(cam_T_world, p, K, b)
        fitted = np.max(np.abs(z - z_pred), axis=1) <= inlier_px
        if np.array_equal(fitted, inliers):
            break
        inliers = fitted
    predicted_disparity = z_pred[:, 0] - z_pred[:, 2]
    if inliers.sum() < 2 or np.any(depth[inliers] < 0.5) or np.any(
            predicted_disparity[inliers] < 0.5):
        return None
    return p, inliers


def track_residuals(features, cam_T_world, K, b):
    """Residuals of every fitted track -> (residual (n,4), frame (n,), track (n,), z (n,4)).

    features: (4, M, T), -1 where unobserved; cam_T_world: (T, 4, 4), NaN where unknown."""
    observed = features[0] >= 0
    known = np.isfinite(cam_T_world[:, 0, 0])
    out = ([], [], [], [])
    for j in range(features.shape[1]):
        frames = np.flatnonzero(observed[j] & known)
        # Split the id into runs of consecutive frames (an id may come back).
        for run in np.split(frames, np.flatnonzero(np.diff(frames) != 1) + 1):
            if run.size < MIN_TRACK:
                continue
            z = features[:, j, run].T
            residual = fit_track(z, cam_T_world[run], K, b)
            if residual is None:
                continue
            track = len(out[0])
            for part, value in zip(out, (residual, run, np.full(run.size, track), z)):
                part.append(value)
    if not out[0]:
        raise ValueError('no track could be fitted')
    return tuple(np.concatenate(part) for part in out)


def _consecutive_pairs(values, frame, track, lag):
    """(n,2,...) pairs of values of one track `lag` frames apart."""
    same = (track[lag:] == track[:-lag]) & (frame[lag:] - frame[:-lag] == lag)
    return np.stack([values[:-lag][same], values[lag:][same]], 1)


def statistics(residual, frame, track, z):
    """Dictionary of the statistics described in the module docstring."""
    inlier = np.all(np.abs(residual) < INLIER_PX, 1)
    r, f, k, zz = residual[inlier], frame[inlier], track[inlier], z[inlier]
    common = np.zeros((int(f.max()) + 1, 4))
    for frame_index in np.unique(f):
        common[frame_index] = np.median(r[f == frame_index], 0)
    result = dict(tracks=int(np.unique(k).size), observations=int(r.shape[0]),
                  inlier_fraction=float(inlier.mean()), std=r.std(0).tolist(),
                  frame_common_std=common[np.unique(f)].std(0).tolist())
    for name, values in (('', r), ('_without_frame_common', r - common[f])):
        result['correlation' + name] = {
            lag: [float(np.corrcoef(p[:, 0, i], p[:, 1, i])[0, 1]) for i in range(4)]
            for lag in LAGS for p in [_consecutive_pairs(values, f, k, lag)]}
    # Random-walk part: the variance of a track's error difference over L frames, a + q L for a
    # white part of variance a / 2 and a random walk of q px^2 per frame, fitted over short lags
    # (the fitted landmark takes up the slow part of long tracks).
    lags = np.array(RANDOM_WALK_LAGS, float)
    variogram = np.array([np.mean(np.diff(_consecutive_pairs(r, f, k, lag), axis=1)[:, 0] ** 2, 0)
                          for lag in RANDOM_WALK_LAGS])
    slope, intercept = np.polyfit(lags, variogram, 1)
    result['random_walk'] = dict(lags=list(RANDOM_WALK_LAGS), variogram_px2=variogram.tolist(),
                                 step_variance_px2_per_frame=slope.tolist(),
                                 white_variance_px2=(intercept / 2.0).tolist())
    rho = float(np.mean(result['correlation'][1]))
    pairs = _consecutive_pairs(r, f, k, 1)
    result['rho'] = rho
    result['differenced_std'] = (pairs[:, 1] - rho * pairs[:, 0]).std(0).tolist()
    disparity = pairs[:, :, 0] - pairs[:, :, 2]
    result['disparity_correlation'] = float(np.corrcoef(disparity[:, 0], disparity[:, 1])[0, 1])
    # Mean drift per frame (residual increments) by where the feature is in the image.
    increment = pairs[:, 1] - pairs[:, 0]
    where = _consecutive_pairs(zz, f, k, 1)[:, 1]
    result['drift_per_frame'] = dict(all=increment.mean(0).tolist(),
                                     standard_error=(increment.std(0) /
                                                     np.sqrt(increment.shape[0])).tolist())
    rows = np.quantile(where[:, 1], [0.0, 0.25, 0.5, 0.75, 1.0])
    columns = np.quantile(where[:, 0], [0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0])
    result['drift_per_frame']['by_row'] = _binned(increment, where[:, 1], rows)
    result['drift_per_frame']['by_column'] = _binned(increment, where[:, 0], columns)
    result['per_track'] = _per_track(r, f, k)
    return result


def _per_track(residual, frame, track):
    """Each track's RMS error (uL, vL, uR: vR repeats vL in a rectified pair) and the slope of
    its uL error against the frame index, over tracks of at least PER_TRACK_MIN observations:
    percentiles, and the share of the squared error held by the 10 % and 25 % of them with the
    largest RMS (white errors of one std: about 0.15 and 0.35, as tracks differ by chance)."""
    order = np.argsort(track, kind='stable')
    starts = np.flatnonzero(np.diff(track[order])) + 1
    rms, slope, squared = [], [], []
    for rows in np.split(order, starts):
        if rows.size < PER_TRACK_MIN:
            continue
        e = residual[rows][:, :3]
        rms.append(np.sqrt(np.mean(e ** 2)))
        slope.append(abs(np.polyfit(frame[rows].astype(float), e[:, 0], 1)[0]))
        squared.append(np.sum(e ** 2))
    if not rms:
        return dict(tracks=0)
    squared = np.asarray(squared)[np.argsort(rms)[::-1]]

    def share(fraction):
        return float(squared[:max(1, int(fraction * squared.size))].sum() / squared.sum())

    return dict(tracks=len(rms),
                rms_percentiles_px=np.percentile(rms, PERCENTILES).tolist(),
                drift_percentiles_px_per_frame=np.percentile(slope, PERCENTILES).tolist(),
                worst_10_percent_share=share(0.10), worst_25_percent_share=share(0.25))


def _binned(values, key, edges):
    bins = []
    for lo, hi in zip(edges[:-1], edges[1:]):
        m = (key >= lo) & (key <= hi)
        bins.append(dict(range_px=[float(lo), float(hi)], count=int(m.sum()),
                         mean=values[m].mean(0).tolist()))
    return bins
