"""Evaluation figures (matplotlib, off-screen Agg canvas; no display and no pyplot state needed).

All inputs are already in the ground-truth world frame (estimates aligned). Top-down views show
two of its axes, chosen by :func:`topdown_axes` so that the view looks down from above (the
ground truth of the course data has world = cam0 at frame 0, i.e. y points down and the ground
is the x-z plane). Figures are written as PNG files.
"""
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

GT_STYLE = dict(color='0.15', linestyle='--', linewidth=1.2)
PRIMARY_COLOR = 'red'
LANDMARK_COLOR = 'green'
#: Colours of further estimates in comparisons (tab10 without red and green).
OTHER_COLORS = ('tab:blue', 'tab:orange', 'tab:purple', 'tab:brown', 'tab:pink', 'tab:olive',
                'tab:cyan', 'tab:gray')
DPI = 150
AXIS_NAMES = 'xyz'


def topdown_axes(gtworld_R_imu, imu_up=(0.0, 0.0, 1.0)):
    """World axes (i, j) to plot horizontally/vertically for a view from above, unmirrored.

    "Up" in the world is the mean over the poses of the IMU's up axis ``imu_up`` (z for the
    x-forward, y-left, z-up IMU of the datasets). The world axis closest to it is left out;
    the other two are ordered so that e_i x e_j points up, towards the viewer. Falls back to
    (x, y) when the orientations do not agree on an up direction (mean shorter than 0.5).
    """
    up = np.einsum('nij,j->i', np.asarray(gtworld_R_imu, dtype=float), np.asarray(imu_up, float))
    up /= max(len(gtworld_R_imu), 1)
    if np.linalg.norm(up) < 0.5:
        return 0, 1
    v = int(np.argmax(np.abs(up)))
    i, j = (v + 1) % 3, (v + 2) % 3  # e_i x e_j = +e_v
    return (i, j) if up[v] > 0 else (j, i)


def parse_axes(spec):
    """'xz' -> (0, 2)."""
    if len(spec) != 2 or spec[0] == spec[1] or any(c not in AXIS_NAMES for c in spec):
        raise ValueError('top-down axes must be two different letters of xyz, got %r' % spec)
    return AXIS_NAMES.index(spec[0]), AXIS_NAMES.index(spec[1])


def estimate_colors(n):
    """Colours of n estimates: the primary (first) one red, the others from OTHER_COLORS."""
    return [PRIMARY_COLOR] + [OTHER_COLORS[i % len(OTHER_COLORS)] for i in range(n - 1)]


def _new_canvas(size):
    fig = Figure(figsize=size)
    FigureCanvasAgg(fig)
    return fig


def _new_figure(size=(8.0, 7.0)):
    fig = _new_canvas(size)
    return fig, fig.add_subplot(1, 1, 1)


def _save(fig, path):
    fig.tight_layout()
    fig.savefig(path, dpi=DPI)


def _topdown_limits(ax, paths_2d, landmarks_2d=None):
    """Equal-axis view around the paths, widened to the bulk (1-99 %) of the landmarks.

    Far outliers of the map would otherwise shrink the trajectory to a dot; they stay plotted
    but fall outside the view.
    """
    pts = np.concatenate(paths_2d)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    if landmarks_2d is not None and len(landmarks_2d) >= 10:
        lo = np.minimum(lo, np.percentile(landmarks_2d, 1, axis=0))
        hi = np.maximum(hi, np.percentile(landmarks_2d, 99, axis=0))
    pad = 0.05 * max(float(np.max(hi - lo)), 1.0)
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad, hi[1] + pad)
    ax.set_aspect('equal', adjustable='datalim')


def _decorate_topdown(ax, title, axes):
    ax.set_xlabel('%s [m] (ground-truth world)' % AXIS_NAMES[axes[0]])
    ax.set_ylabel('%s [m] (ground-truth world)' % AXIS_NAMES[axes[1]])
    ax.set_title(title)
    ax.grid(True, linewidth=0.3, alpha=0.5)
    handles, labels = ax.get_legend_handles_labels()
    # Tiny landmark dots get a readable legend marker of their own.
    handles = [Line2D([], [], color=LANDMARK_COLOR, marker='o', markersize=4, linestyle='')
               if label.startswith('landmarks') else h for h, label in zip(handles, labels)]
    ax.legend(handles, labels, loc='best', fontsize='small')


def plot_topdown(path, gt_xyz, est_xyz, landmarks_xyz=None, label='estimate', ate_rmse_m=None,
                 axes=(0, 1)):
    """Top-down figure: ground truth dashed dark grey, aligned estimate red, landmarks green dots.

    ``gt_xyz``, ``est_xyz``: (N, 3) positions; ``landmarks_xyz``: (M, 3) aligned landmarks or
    None; ``axes``: the world axes to plot (see :func:`topdown_axes`). Thousands of landmarks
    are drawn as tiny rasterised dots.
    """
    axes = list(axes)
    gt_2d, est_2d = gt_xyz[:, axes], est_xyz[:, axes]
    landmarks_2d = None
    fig, ax = _new_figure()
    if landmarks_xyz is not None and len(landmarks_xyz):
        landmarks_2d = landmarks_xyz[:, axes]
        ax.scatter(landmarks_2d[:, 0], landmarks_2d[:, 1], s=1.5, c=LANDMARK_COLOR,
                   marker='.', linewidths=0, alpha=0.7, rasterized=True,
                   label='landmarks (%d)' % len(landmarks_2d))
    ax.plot(gt_2d[:, 0], gt_2d[:, 1], label='ground truth', **GT_STYLE)
    ax.plot(est_2d[:, 0], est_2d[:, 1], color=PRIMARY_COLOR, linewidth=1.4, label=label)
    ax.plot(gt_2d[0, 0], gt_2d[0, 1], 'k^', markersize=6, label='start')
    _topdown_limits(ax, [gt_2d, est_2d], landmarks_2d)
    title = 'Top-down view: %s' % label
    if ate_rmse_m is not None:
        title += ' (ATE RMSE %.2f m)' % ate_rmse_m
    _decorate_topdown(ax, title, axes)
    _save(fig, path)


def plot_error_along_path(path, series):
    """Position error vs ground-truth distance travelled.

    ``series``: list of (label, distance_m[N], position_error_m[N]); the first is the primary.
    """
    fig, ax = _new_figure(size=(9.0, 4.5))
    for (label, distance, error), color in zip(series, estimate_colors(len(series))):
        ax.plot(distance, error, color=color, linewidth=1.2,
                label='%s (RMSE %.2f m)' % (label, float(np.sqrt(np.mean(np.square(error))))))
    ax.set_xlabel('distance travelled [m] (ground truth)')
    ax.set_ylabel('position error after alignment [m]')
    ax.set_title('Position error along the path')
    ax.set_xlim(left=0.0)
    ax.set_ylim(bottom=0.0)
    ax.grid(True, linewidth=0.3, alpha=0.5)
    ax.legend(loc='best', fontsize='small')
    _save(fig, path)


def plot_comparison(path, gt_xyz, estimates, axes=(0, 1)):
    """Top-down comparison of several aligned estimates against the ground truth.

    ``estimates``: list of (label, est_xyz[N, 3], ate_rmse_m); the first is the primary (red).
    ``axes``: the world axes to plot (see :func:`topdown_axes`).
    """
    axes = list(axes)
    gt_2d = gt_xyz[:, axes]
    fig, ax = _new_figure()
    ax.plot(gt_2d[:, 0], gt_2d[:, 1], label='ground truth', **GT_STYLE)
    paths_2d = [gt_2d]
    for (label, est_xyz, ate_rmse_m), color in zip(estimates, estimate_colors(len(estimates))):
        est_2d = est_xyz[:, axes]
        paths_2d.append(est_2d)
        ax.plot(est_2d[:, 0], est_2d[:, 1], color=color, linewidth=1.2,
                label='%s (ATE %.2f m)' % (label, ate_rmse_m))
    ax.plot(gt_2d[0, 0], gt_2d[0, 1], 'k^', markersize=6, label='start')
    _topdown_limits(ax, paths_2d)
    _decorate_topdown(ax, 'Aligned trajectories vs ground truth', axes)
    _save(fig, path)


def plot_consistency(path, label, series, summary, chi2_95):
    """Where the reported covariance is right, too wide or too narrow, over time.

    ``series``: :func:`ekf_vislam_tools.metrics.consistency_series`'s dict, ``summary``: its
    :func:`ekf_vislam_tools.metrics.consistency_summary` (the means and RMS in the legends);
    ``chi2_95``: the chi-square 95 % bounds by dof. Top: position and pose NEES per pose (log
    scale) with their dof (the consistent mean) and 95 % bounds; bottom: error / sigma per world
    axis, with +-2.
    """
    t = series['t'] - series['t'][0]
    fig = _new_canvas((9.0, 7.0))
    top, bottom = fig.add_subplot(2, 1, 1), fig.add_subplot(2, 1, 2)
    for name, dof, color in (('position', 3, 'tab:blue'), ('pose', 6, 'tab:orange')):
        top.plot(t, np.maximum(series[name + '_nees'], 1e-6), color=color, linewidth=0.9,
                 label='%s NEES (mean %.2f; %d is consistent)'
                 % (name, summary['nees_' + name]['mean'], dof))
        top.axhline(dof, color=color, linewidth=0.8, linestyle=':')
        top.axhline(chi2_95[dof], color=color, linewidth=0.8, linestyle='--')
    top.set_yscale('log')
    top.set_ylabel('NEES (dotted: dof, dashed: 95 %)')
    top.set_title('Reported covariance against the errors: %s' % label)
    top.legend(loc='best', fontsize='small')
    normalized = series['errors'] / series['sigmas']
    colors = ('tab:blue', 'tab:orange', 'tab:green', 'tab:red', 'tab:purple', 'tab:brown')
    for i, ((axis, rms), color) in enumerate(zip(summary['error_over_sigma_rms'].items(), colors)):
        bottom.plot(t, normalized[:, i], color=color, linewidth=0.8,
                    label='%s (RMS %.2f)' % (axis.replace('_', ' '), rms))
    for level in (-2.0, 2.0):
        bottom.axhline(level, color='0.3', linewidth=0.8, linestyle='--')
    bottom.set_xlabel('time since the first pose [s]')
    bottom.set_ylabel('error / sigma (world axes)')
    bottom.legend(loc='best', fontsize='small', ncol=3)
    for ax in (top, bottom):
        ax.grid(True, linewidth=0.3, alpha=0.5)
    _save(fig, path)
