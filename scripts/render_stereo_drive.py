#!/usr/bin/python3
"""Render a synthetic stereo drive with known poses, in the KITTI odometry folder layout.

    render_stereo_drive.py OUT_FOLDER [--frames 500] [--seed 0] [--width 640 --height 192]

The world: a textured ground plane (z = 0) between two textured walls 6 m high (y = +8 m and
y = -9 m), a sky above; world axes x forward at the start, y left, z up. The car drives along x
at --speed m/s, weaving sideways (sinusoid of --weave m amplitude, heading along the path), the
left camera 1.65 m above the ground. Each image is ray-cast (ray-plane intersection, numpy) and
its texture sampled bilinearly from a seeded noise atlas; the rectified right camera sits
--baseline m to the left camera's right. Writes image_left/NNNNNN.png, image_right/NNNNNN.png,
calib.txt (P0, P1), times.txt (10 Hz), poses.txt (world_T_cam0, world = cam0 at frame 0) and
depth_left/NNNNNN.npy (float32 z depth of every left pixel, m; inf = sky: the pixel truth).
"""
import argparse
import os
import sys

import cv2
import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', 'src'))
from ekf_vislam_tools import stereo_images  # noqa: E402

PROG = 'render_stereo_drive.py'
CAMERA_HEIGHT = 1.65
WALL_LEFT_Y, WALL_RIGHT_Y, WALL_HEIGHT = 8.0, -9.0, 6.0
TEXTURE_PX_PER_M = 24.0
FOG_START, FOG_END = 50.0, 90.0


def parse_args(argv):
    p = argparse.ArgumentParser(prog=PROG, description=__doc__.split('\n\n')[0])
    p.add_argument('out')
    p.add_argument('--frames', type=int, default=500)
    p.add_argument('--seed', type=int, default=0)
    p.add_argument('--width', type=int, default=640)
    p.add_argument('--height', type=int, default=192)
    p.add_argument('--focal', type=float, default=370.0, help='px (KITTI-like field of view)')
    p.add_argument('--baseline', type=float, default=0.54, help='m')
    p.add_argument('--speed', type=float, default=8.0, help='m/s')
    p.add_argument('--weave', type=float, default=2.0, help='m, sideways sinusoid amplitude')
    p.add_argument('--weave-period', type=float, default=14.0, help='s')
    return p.parse_args(argv)


def make_atlas(seed, size=2048):
    """Gray noise with structure at several scales (corners to track at every distance)."""
    rng = np.random.default_rng(seed)
    atlas = np.zeros((size, size), np.float32)
    for scale, weight in ((2, 0.35), (6, 0.35), (24, 0.3)):
        small = rng.random((size // scale, size // scale)).astype(np.float32)
        atlas += weight * cv2.resize(small, (size, size), interpolation=cv2.INTER_CUBIC)
    atlas = cv2.GaussianBlur(atlas, (0, 0), 0.8)
    atlas = (atlas - atlas.min()) / (atlas.max() - atlas.min())
    return (40 + 190 * atlas).astype(np.float32)


def pose_at(t, args):
    """world_T_cam (4x4) of the left camera at time t."""
    w = 2 * np.pi / args.weave_period
    x, y = args.speed * t, args.weave * np.sin(w * t)
    yaw = np.arctan2(args.weave * w * np.cos(w * t), args.speed)
    forward = np.array([np.cos(yaw), np.sin(yaw), 0.0])
    right = np.array([np.sin(yaw), -np.cos(yaw), 0.0])
    down = np.array([0.0, 0.0, -1.0])
    T = np.eye(4)
    T[:3, :3] = np.stack([right, down, forward], axis=1)
    T[:3, 3] = [x, y, CAMERA_HEIGHT]
    return T


def render(world_T_cam, K, size, atlas):
    """(image uint8, z depth float32) of a camera; rays through pixel centres."""
    width, height = size
    u, v = np.meshgrid(np.arange(width, dtype=np.float64), np.arange(height, dtype=np.float64))
    d_cam = np.stack([(u - K[0, 2]) / K[0, 0], (v - K[1, 2]) / K[1, 1], np.ones_like(u)], -1)
    d = d_cam @ world_T_cam[:3, :3].T
    c = world_T_cam[:3, 3]
    best = np.full(u.shape, np.inf)
    tex_x = np.zeros(u.shape)
    tex_y = np.zeros(u.shape)
    with np.errstate(divide='ignore', invalid='ignore'):
        s = -c[2] / d[..., 2]  # ground z = 0
        hit = (s > 0) & np.isfinite(s)
        best = np.where(hit, s, best)
        tex_x = np.where(hit, c[0] + s * d[..., 0], tex_x)
        tex_y = np.where(hit, c[1] + s * d[..., 1] + 500.0, tex_y)
        for wall_y, offset in ((WALL_LEFT_Y, 1000.0), (WALL_RIGHT_Y, 1500.0)):
            s = (wall_y - c[1]) / d[..., 1]
            z = c[2] + s * d[..., 2]
            hit = (s > 0) & (s < best) & (z >= 0) & (z <= WALL_HEIGHT)
            best = np.where(hit, s, best)
            tex_x = np.where(hit, c[0] + s * d[..., 0], tex_x)
            tex_y = np.where(hit, z + offset, tex_y)
    # Wrapped into the atlas here: cv2.remap saturates coordinates beyond 32767 px (it converts
    # them to 16-bit fixed point), which smeared the right wall (texture offset 1500 m) into
    # vertical stripes.
    map_x = np.mod(tex_x * TEXTURE_PX_PER_M, atlas.shape[1]).astype(np.float32)
    map_y = np.mod(tex_y * TEXTURE_PX_PER_M, atlas.shape[0]).astype(np.float32)
    image = cv2.remap(atlas, map_x, map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_WRAP)
    depth = np.where(np.isfinite(best), best, np.inf)  # d_cam has z = 1: s is the z depth
    fog = np.clip((depth - FOG_START) / (FOG_END - FOG_START), 0, 1)
    sky = 200.0 - 60.0 * v / height
    image = np.where(np.isfinite(depth), (1 - fog) * image + fog * sky, sky)
    return np.clip(image, 0, 255).astype(np.uint8), depth.astype(np.float32)


def main(argv):
    args = parse_args(argv)
    if args.frames < 2 or args.width < 64 or args.height < 64:
        print('%s: need at least 2 frames and 64x64 images' % PROG, file=sys.stderr)
        return 2
    for sub in ('image_left', 'image_right', 'depth_left'):
        os.makedirs(os.path.join(args.out, sub), exist_ok=True)
    K = np.array([[args.focal, 0, args.width / 2.0 - 0.5], [0, args.focal, args.height / 2.0 - 0.5],
                  [0, 0, 1]])
    atlas = make_atlas(args.seed)
    times = 0.1 * np.arange(args.frames)
    first_inv = np.linalg.inv(pose_at(0.0, args))
    poses = []
    for k, t in enumerate(times):
        world_T_left = pose_at(t, args)
        poses.append(first_inv @ world_T_left)
        world_T_right = world_T_left.copy()
        world_T_right[:3, 3] += args.baseline * world_T_left[:3, 0]
        left, depth = render(world_T_left, K, (args.width, args.height), atlas)
        right, _ = render(world_T_right, K, (args.width, args.height), atlas)
        cv2.imwrite(os.path.join(args.out, 'image_left', '%06d.png' % k), left)
        cv2.imwrite(os.path.join(args.out, 'image_right', '%06d.png' % k), right)
        np.save(os.path.join(args.out, 'depth_left', '%06d.npy' % k), depth)
    stereo_images.write_metadata(args.out, K, args.baseline, times, poses)
    print('%s: %d frames, %.1f m -> %s' % (PROG, args.frames,
                                            args.speed * times[-1], args.out))
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
