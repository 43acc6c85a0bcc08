#!/usr/bin/python3
"""Copy a stereo image folder (KITTI odometry layout) with its brightness changed, as a camera's
automatic exposure or a pair of unequal cameras would change it.

    exposure_variant.py FOLDER OUT_FOLDER [--jitter 0.15] [--right-jitter 0.1]
                        [--right-gain 1.0] [--right-offset 0] [--step-frame N --step-gain G]
                        [--seed 0]

Each frame's images are multiplied by exp(u), u uniform in [-jitter, jitter] (the same for both
cameras: a shared exposure), the right one also by exp(r), r uniform in [-right-jitter,
right-jitter], and by --right-gain plus --right-offset gray levels; from --step-frame on, both
by --step-gain as well. Values saturate at 0 and 255. calib.txt, times.txt and poses.txt (if
any) are copied, so track_stereo_images and images_end_to_end.sh take OUT_FOLDER as they take
FOLDER. A check of the tracker's exposure compensation (klt/exposure_compensation).
"""
import argparse
import os
import shutil
import sys

import cv2
import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', 'src'))
from ekf_vislam_tools import stereo_images  # noqa: E402

PROG = 'exposure_variant.py'


def parse_args(argv):
    p = argparse.ArgumentParser(prog=PROG, description=__doc__.split('\n\n')[0])
    p.add_argument('folder')
    p.add_argument('out_folder')
    p.add_argument('--jitter', type=float, default=0.15,
                   help='per-frame log gain of both cameras, uniform in +-this')
    p.add_argument('--right-jitter', type=float, default=0.0,
                   help='per-frame log gain of the right camera alone, uniform in +-this')
    p.add_argument('--right-gain', type=float, default=1.0)
    p.add_argument('--right-offset', type=float, default=0.0, help='gray levels')
    p.add_argument('--step-frame', type=int, default=-1, help='from this frame on, --step-gain')
    p.add_argument('--step-gain', type=float, default=1.0)
    p.add_argument('--seed', type=int, default=0)
    return p.parse_args(argv)


def main(argv):
    args = parse_args(argv)
    sources = dict(zip(('image_left', 'image_right'), stereo_images.image_folders(args.folder)))
    names = sorted(os.listdir(sources['image_left']))
    if not names:
        sys.exit(f'{PROG}: no images in {sources["image_left"]}')
    rng = np.random.default_rng(args.seed)
    log_gain = rng.uniform(-args.jitter, args.jitter, len(names))
    log_right = rng.uniform(-args.right_jitter, args.right_jitter, len(names))
    for side in ('image_left', 'image_right'):
        os.makedirs(os.path.join(args.out_folder, side), exist_ok=True)
    for k, name in enumerate(names):
        gain = np.exp(log_gain[k]) * (args.step_gain if 0 <= args.step_frame <= k else 1.0)
        for side in ('image_left', 'image_right'):
            path = os.path.join(sources[side], name)
            image = cv2.imread(path, cv2.IMREAD_UNCHANGED)
            if image is None:
                sys.exit(f'{PROG}: cannot read {path}')
            g, offset = gain, 0.0
            if side == 'image_right':
                g *= np.exp(log_right[k]) * args.right_gain
                offset = args.right_offset
            out = np.clip(image.astype(np.float32) * g + offset, 0, 255).astype(np.uint8)
            cv2.imwrite(os.path.join(args.out_folder, side, name), out)
    for name in ('calib.txt', 'times.txt', 'poses.txt'):
        if os.path.exists(os.path.join(args.folder, name)):
            shutil.copy(os.path.join(args.folder, name), os.path.join(args.out_folder, name))
    print(f'{PROG}: {len(names)} pairs written to {args.out_folder}')


if __name__ == '__main__':
    main(sys.argv[1:])
