#!/usr/bin/python3
"""Copy a stereo image folder (KITTI odometry layout) as another regime of the same scene, with
its calibration, times and poses made to match, so that track_stereo_images and
images_end_to_end.sh take the copy as they take the folder. For checking that the tracker and
its settings hold beyond the clips they were measured on.

    image_variant.py FOLDER OUT_FOLDER [--step N] [--reverse] [--hold K:N] [--mirror]
                     [--scale S] [--right-shift DX] [--right-roll DEG] [--noise SIGMA]
                     [--seed 0]

--step N     every Nth frame only (times kept): a slower frame rate, N times the motion per
             pair (2: KITTI at 5 Hz).
--reverse    the frames in reverse order, times from the source's first on: the camera
             drives backwards, points come from the image's middle instead of leaving by its
             borders.
--hold K:N   the variant's frame K shown N more times, the interval between them the median
             one: a stop (with --noise each copy gets its own noise; without, they are the same
             bytes, as from a driver that repeats a frame).
--mirror     both images flipped left to right and exchanged (the flipped right image becomes the
             left one): the scene mirrored, a valid rectified rig with the same baseline;
             cx becomes width - 1 - cx and the poses are mirrored too (turns go the other way).
--scale S    both images resized by S (cv2.INTER_AREA below 1, INTER_LINEAR above), K scaled
             about the pixel centres: fx' = S fx, cx' = S (cx + 0.5) - 0.5.
--right-shift DX
             the right image moved right by DX px (cv2.warpAffine, bilinear, border reflected),
             the calibration kept: every measured disparity DX px smaller than the true one, as
             from a rig whose right camera's cx disagrees with its images (the tracker's rig
             check reports a disparity offset of -DX). Whole pixels move the image without
             resampling it.
--right-roll DEG
             the right image turned DEG degrees clockwise as displayed about the principal point
             (cv2.warpAffine, bilinear, border reflected), the calibration kept: rows apart by
             DEG (u - cx) in radians, as from a rig whose rectification leaves the right camera
             turned about its optical axis (the tracker's rig check reports a roll of DEG).
--noise S    Gaussian noise of S gray levels added to every pixel, drawn anew for each image
             (--seed), saturated at 0 and 255.

The options combine (applied in the order above). The poses stay world_T_cam0 with the world at
the new first frame's left camera. The images are written as 8-bit PNG, colour kept.
"""
import argparse
import os
import sys

import cv2
import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', 'src'))
from ekf_vislam_tools import stereo_images  # noqa: E402
from ekf_vislam_tools.image_variants import (frame_order, mirrored_calibration,  # noqa: E402
                                             parse_hold, right_image_warp, scaled_calibration,
                                             variant_poses, variant_times)

PROG = 'image_variant.py'


def parse_args(argv):
    p = argparse.ArgumentParser(prog=PROG, description=__doc__.split('\n\n')[0])
    p.add_argument('folder')
    p.add_argument('out_folder')
    p.add_argument('--step', type=int, default=1, help='keep every Nth frame')
    p.add_argument('--reverse', action='store_true', help='frames in reverse order')
    p.add_argument('--hold', default=None, metavar='K:N',
                   help='repeat the variant\'s frame K N more times (a stop)')
    p.add_argument('--mirror', action='store_true', help='mirror the scene (flip and exchange)')
    p.add_argument('--scale', type=float, default=1.0, help='image scale factor')
    p.add_argument('--right-shift', type=float, default=0.0,
                   help='move the right image right by this many px')
    p.add_argument('--right-roll', type=float, default=0.0,
                   help='turn the right image clockwise by this many degrees')
    p.add_argument('--noise', type=float, default=0.0, help='pixel noise std, gray levels')
    p.add_argument('--seed', type=int, default=0)
    return p.parse_args(argv)


def variant_image(path, flip, scale, warp, noise, rng):
    image = cv2.imread(path, cv2.IMREAD_UNCHANGED)
    if image is None:
        sys.exit('%s: cannot read %s' % (PROG, path))
    if flip:
        image = cv2.flip(image, 1)
    if scale != 1.0:
        size = (int(round(image.shape[1] * scale)), int(round(image.shape[0] * scale)))
        image = cv2.resize(image, size,
                           interpolation=cv2.INTER_AREA if scale < 1 else cv2.INTER_LINEAR)
    if warp is not None:
        image = cv2.warpAffine(image, warp, (image.shape[1], image.shape[0]),
                               flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT)
    if noise > 0:
        image = np.clip(image.astype(np.float32) + rng.normal(0.0, noise, image.shape), 0, 255)
    return image.astype(np.uint8)


def main(argv):
    args = parse_args(argv)
    if args.step < 1 or not args.scale > 0 or args.noise < 0:
        print('%s: --step >= 1, --scale > 0, --noise >= 0' % PROG, file=sys.stderr)
        return 2
    try:
        source = stereo_images.load_folder(args.folder)
    except (OSError, ValueError) as e:
        print('%s: %s' % (PROG, e), file=sys.stderr)
        return 2
    try:
        hold = parse_hold(args.hold, len(frame_order(len(source.left), args.step, args.reverse)))
    except ValueError as e:
        print('%s: %s' % (PROG, e), file=sys.stderr)
        return 2
    order = frame_order(len(source.left), args.step, args.reverse, hold)
    if len(order) < 2:
        print('%s: fewer than 2 frames left' % PROG, file=sys.stderr)
        return 2
    width = cv2.imread(source.left[0], cv2.IMREAD_UNCHANGED).shape[1]
    K = mirrored_calibration(source.K, width) if args.mirror else source.K
    K = scaled_calibration(K, args.scale)
    lefts, rights = source.left, source.right
    if args.mirror:
        lefts, rights = rights, lefts
    rng = np.random.default_rng(args.seed)
    for side in ('image_left', 'image_right'):
        os.makedirs(os.path.join(args.out_folder, side), exist_ok=True)
    warp = right_image_warp(args.right_shift, args.right_roll, (K[0, 2], K[1, 2]))
    for k, i in enumerate(order):
        for side, paths, side_warp in (('image_left', lefts, None), ('image_right', rights, warp)):
            image = variant_image(paths[i], args.mirror, args.scale, side_warp, args.noise, rng)
            cv2.imwrite(os.path.join(args.out_folder, side, '%06d.png' % k), image)
    poses = (None if source.world_T_cam is None
             else variant_poses(source.world_T_cam, order, args.mirror, source.b))
    stereo_images.write_metadata(args.out_folder, K, source.b, variant_times(source.times, order),
                                 poses)
    print('%s: %d pairs written to %s' % (PROG, len(order), args.out_folder))
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
