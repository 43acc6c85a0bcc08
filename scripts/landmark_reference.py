#!/usr/bin/python3
"""Reference landmarks for a real dataset: each track triangulated from the ground-truth poses.

    landmark_reference.py DATA.npz --groundtruth GT --out REF.csv

A real dataset has no true landmarks, so the map's errors and its reported sigmas cannot be
checked as on a simulated drive. This gives each id the world point that best explains all its
stereo observations from the ground-truth camera poses (Gauss-Newton with Huber weights from its
first observation, then the observations off by more than 6 px left out and the point fitted
again; ekf_vislam_tools/track_errors.py, fit_landmark). REF.csv (id,x,y,z in the ground truth's
world, and the observations kept) then stands for the true landmarks:

    evaluate.py --estimate RUN/trajectory.tum --groundtruth GT \\
        --landmarks RUN/landmarks.csv --landmarks-gt REF.csv --out DIR

The reference shares the tracks' own errors with the estimate, which read the same
observations: its error against the estimate leaves out the part of the landmark's error that the
tracks make, so the map's NEES against it is a lower bound. On simulated drives (exact landmarks
known) the two read (diagonal NEES, 3 is consistent): white 2 px tracks 1.81 against the reference,
2.41 against the truth; drifting tracks 5.29 and 5.46 (doc/experiments.md).

GT holds world_T_imu (TUM; frames matched to the dataset by time stamp) or is a KITTI poses file
(world_T_cam0, a line per dataset frame). Ids seen in fewer than 2 frames with ground truth, or
whose fit fails (fewer than 2 observations within 6 px, a point closer than 0.5 m to a camera
or at a disparity below 0.5 px), get no row. A dataset whose feature columns each hold several tracks (feature_columns_shared)
is refused: its ids are not one landmark each.

Exit status: 0 on success, 2 on unusable input (one-line message on stderr).
"""
import argparse
import sys

import numpy as np

from ekf_vislam_tools import dataset, track_errors

PROG = 'landmark_reference.py'


def references(data, cam_T_world):
    """-> list of (id, p_world (3,), observations kept), for each id that can be fitted."""
    observed = data.observed() & np.isfinite(cam_T_world[:, 0, 0])[None, :]
    rows = []
    for j in np.flatnonzero(observed.sum(axis=1) >= 2):
        frames = np.flatnonzero(observed[j])
        fit = track_errors.fit_landmark(data.features[:, j, frames].T, cam_T_world[frames],
                                        data.K, data.b)
        if fit is not None:
            rows.append((int(j), fit[0], int(fit[1].sum())))
    return rows


def write_csv(path, rows):
    with open(path, 'w') as f:
        f.write('id,x,y,z,observations\n')
        for j, p, kept in rows:
            f.write('%d,%.6f,%.6f,%.6f,%d\n' % (j, p[0], p[1], p[2], kept))


def main(argv):
    parser = argparse.ArgumentParser(prog=PROG, description=__doc__.split('\n')[0])
    parser.add_argument('dataset', help='course npz (either layout)')
    parser.add_argument('--groundtruth', required=True, metavar='GT',
                        help='world_T_imu poses (TUM), or KITTI poses of world_T_cam0')
    parser.add_argument('--out', required=True, metavar='REF.csv', help='reference landmarks')
    args = parser.parse_args(argv)
    try:
        data = dataset.load_dataset(args.dataset, fix_twist_axes=False)  # the twist is not used
        if data.columns_shared:
            raise ValueError('%s: its feature columns each hold several tracks '
                             '(feature_columns_shared): an id is not one landmark'
                             % args.dataset)
        rows = references(data, track_errors.camera_poses(data, args.groundtruth))
        write_csv(args.out, rows)
    except (OSError, ValueError) as error:
        print('%s: %s' % (PROG, ' '.join(str(error).split())), file=sys.stderr)
        return 2
    seen = int(np.count_nonzero(data.observed().any(axis=1)))
    print('%s: %d of %d ids seen fitted -> %s' % (PROG, len(rows), seen, args.out))
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
