"""Other vehicles on a simulated road: rigid clusters of points that move (traffic).

A real tracker also tracks corners on the cars around it. Their points are not fixed in the
world: a car ahead driving at the ego vehicle's speed stays where it is in the image, an oncoming
car closes at the sum of both speeds. `vehicle_tracks` draws such cars along a simulated drive and
tracks the corners on their faces towards the camera as the static scene's tracks are tracked (one
contiguous id per track, lost with the same per-frame probability).

- **Cars ahead** (`vehicles_ahead`): each drives in the ego lane or the one to its left, 10-35 m
  ahead along the road; the gap breathes by up to 30 % over 10-40 s, so its speed follows the ego's
  with a small difference (it stops where the ego vehicle stops).
- **Oncoming cars** (`oncoming_per_minute`): Poisson arrivals; each appears 80 m ahead in the lane
  to the left and drives towards the camera at 8-14 m/s until it is behind it.

A car is 4.5 m long and 1.8 m wide, its body from 0.9 m below the IMU's height to 0.6 m above;
its corners lie on the face towards the ego vehicle (the rear of a car ahead, the front of an
oncoming one) and on both sides, each seen only from outside its face.
"""
import numpy as np

CAR_LENGTH, CAR_WIDTH = 4.5, 1.8
CAR_BOTTOM, CAR_TOP = -0.9, 0.6
LANE_WIDTH = 3.5
POINTS_PER_FACE = 8
AHEAD_GAP_M = (10.0, 35.0)
ONCOMING_START_M = 80.0
ONCOMING_SPEED_M_S = (8.0, 14.0)


def _car_points(rng, facing):
    """Corners of one car in its own frame (x forward, y left, z up) -> (points (P,3), outward
    normals (P,3)): POINTS_PER_FACE on the face towards `facing` (-1: the rear, +1: the front)
    and on each side."""
    half_l, half_w = 0.5 * CAR_LENGTH, 0.5 * CAR_WIDTH
    n = POINTS_PER_FACE
    height = rng.uniform(CAR_BOTTOM, CAR_TOP, 3 * n)
    end = np.stack([np.full(n, facing * half_l), rng.uniform(-half_w, half_w, n), height[:n]], 1)
    sides = []
    for i, side in enumerate((-1.0, 1.0)):
        along = rng.uniform(-half_l, half_l, n)
        sides.append(np.stack([along, np.full(n, side * half_w), height[(i + 1) * n:(i + 2) * n]],
                              1))
    points = np.concatenate([end] + sides)
    normals = np.zeros_like(points)
    normals[:n, 0] = facing
    normals[n:2 * n, 1] = -1.0
    normals[2 * n:, 1] = 1.0
    return points, normals


class _RoadPath:
    """The drive's path by distance travelled (extended straight beyond both ends)."""

    def __init__(self, path, heading, arc):
        self.path, self.heading, self.arc = path, heading, arc

    def frame(self, s, lateral, direction):
        """World pose (R (3,3), p (3,)) of a car at distance s, `lateral` m left of the path,
        driving along it (direction +1) or against it (-1); level, at the path's height."""
        p = np.array([np.interp(s, self.arc, self.path[:, i]) for i in range(3)])
        h = np.array([np.interp(s, self.arc, self.heading[:, i]) for i in range(2)])
        h /= np.linalg.norm(h)
        left = np.array([-h[1], h[0], 0.0])
        p += lateral * left
        x_axis = direction * np.array([h[0], h[1], 0.0])
        return np.stack([x_axis, direction * left, [0.0, 0.0, 1.0]], axis=1), p


def _cars(rng, t, arc, opts):
    """The cars of a drive -> list of (distance along the path per frame (T,), NaN where the car
    is not on the road, lateral m, direction, facing)."""
    cars = []
    tau = t - t[0]
    for _ in range(int(opts['vehicles_ahead'])):
        gap = rng.uniform(*AHEAD_GAP_M)
        periods = rng.uniform(10.0, 40.0, 2)
        phase = rng.uniform(0.0, 2.0 * np.pi, 2)
        breathe = 0.15 * (np.sin(2 * np.pi * tau / periods[0] + phase[0])
                          + np.sin(2 * np.pi * tau / periods[1] + phase[1]))
        lateral = LANE_WIDTH * rng.integers(0, 2)
        cars.append((arc + gap * (1.0 + breathe), lateral, 1.0, -1.0))
    rate = float(opts['oncoming_per_minute'])
    arrival = rng.exponential(60.0 / rate) if rate > 0 else np.inf
    while arrival < tau[-1]:
        k0 = int(np.searchsorted(tau, arrival))
        speed = rng.uniform(*ONCOMING_SPEED_M_S)
        s = arc[k0] + ONCOMING_START_M - speed * (tau - tau[k0])
        s[:k0] = np.nan
        s[s < arc - CAR_LENGTH - 20.0] = np.nan
        cars.append((s, LANE_WIDTH, -1.0, 1.0))
        arrival += rng.exponential(60.0 / rate)
    return cars


def vehicle_tracks(rng, t, world_T_imu, frame_arc, road, camera, opts):
    """Tracks of the corners on the cars of a drive.

    frame_arc (T,): the distance travelled at each frame; road: (path (N,3), heading (N,3),
    arc (N,)), the drive's path by distance; camera: (cam_T_imu (4,4), observe(points,
    world_T_imu) -> (z (P,4), visible (P,) bool)). Returns (frame, track id from 0, z_true (n,4),
    first world position of each id (M,3)) in frame order.
    """
    cam_T_imu, observe = camera
    path = _RoadPath(*road)
    cars = _cars(rng, t, frame_arc, opts)
    shapes = [_car_points(rng, facing) for *_, facing in cars]
    count = sum(len(points) for points, _ in shapes)
    active_id = np.full(count, -1, dtype=np.int64)
    frames, ids, zs, first = [], [], [], []
    for k in range(len(t)):
        camera_in_world = (world_T_imu[k] @ np.linalg.inv(cam_T_imu))[:3, 3]
        offset = 0
        for (s, lateral, direction, _), (points, normals) in zip(cars, shapes):
            span = slice(offset, offset + len(points))
            offset += len(points)
            if np.isnan(s[k]):
                active_id[span] = -1
                continue
            R, p = path.frame(s[k], lateral, direction)
            world = points @ R.T + p
            facing_camera = np.einsum('ij,ij->i', normals @ R.T, camera_in_world - world) > 0
            z, visible = observe(world, world_T_imu[k])
            seen = visible & facing_camera
            going = seen & (active_id[span] >= 0) & (rng.random(len(points)) >= opts['track_loss'])
            ids_here = np.where(going, active_id[span], -1)
            for i in np.flatnonzero(seen & ~going):
                ids_here[i] = len(first)
                first.append(world[i])
            active_id[span] = ids_here
            frames.append(np.full(int(seen.sum()), k))
            ids.append(ids_here[seen])
            zs.append(z[seen])
    if not first:
        return (np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, 4)),
                np.zeros((0, 3)))
    return (np.concatenate(frames), np.concatenate(ids), np.concatenate(zs), np.array(first))
