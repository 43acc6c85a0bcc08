#!/usr/bin/python3
"""Tests of scripts/compare_runs.py (unittest, under a second).

Run: cd test/python && /usr/bin/python3 -m unittest -v test_compare_runs
"""
import json
import os
import unittest

from ekf_test_paths import make_temp_dir, run_script

STATS = {
    'mode': 'slam', 'frames': 3, 'landmarks': 10, 'wall_s': 0.5, 'realtime_factor': 20.0,
    'frame_ms': {'mean': 1.0, 'p50': 1.0, 'p95': 2.0, 'p99': 2.0, 'max': 3.0},
    'counters': {'obs_gated': 4, 'landmark_initialized': 10}, 'peak_rss_mb': 50.0,
    'disparity_offset_px': 0.5,
}
POSES = [(100.0, 0.0, 0.0, 0.0), (100.1, 1.0, 0.0, 0.0), (100.2, 2.0, 0.5, 0.0)]


def write_run(folder, poses=POSES, stats=STATS):
    os.makedirs(folder, exist_ok=True)
    with open(os.path.join(folder, 'trajectory.tum'), 'w') as f:
        for t, x, y, z in poses:
            f.write('%.9f %.9f %.9f %.9f 0 0 0 1\n' % (t, x, y, z))
    with open(os.path.join(folder, 'stats.json'), 'w') as f:
        json.dump(stats, f)
    with open(os.path.join(folder, 'landmarks.csv'), 'w') as f:
        f.write('id,x,y,z,sigma_x,sigma_y,sigma_z,observations\n1,1,2,3,0.1,0.1,0.1,2\n')
    return folder


class CompareRunsTest(unittest.TestCase):
    def setUp(self):
        self.dir = make_temp_dir(self)
        self.a = write_run(os.path.join(self.dir, 'a'))

    def compare(self, b, *extra):
        return run_script('compare_runs.py', self.a, b, *extra, timeout=60)

    def test_identical_runs_pass_and_timing_is_ignored(self):
        stats = dict(STATS, wall_s=9.0, realtime_factor=1.0, peak_rss_mb=80.0,
                     frame_ms=dict(STATS['frame_ms'], p99=7.0))
        proc = self.compare(write_run(os.path.join(self.dir, 'b'), stats=stats))
        self.assertEqual(proc.returncode, 0, proc.stdout + proc.stderr)
        self.assertIn('max position difference 0 m', proc.stdout)
        self.assertIn('counters: all equal', proc.stdout)

    def test_position_difference_against_the_tolerance(self):
        moved = [POSES[0], POSES[1], (100.2, 2.0, 0.5, 3e-6)]
        b = write_run(os.path.join(self.dir, 'b'), poses=moved)
        proc = self.compare(b)
        self.assertEqual(proc.returncode, 1, proc.stdout)
        self.assertIn('max position difference 3e-06 m', proc.stdout)
        self.assertEqual(self.compare(b, '--tolerance', '1e-5').returncode, 0)

    def test_missing_stamp_is_a_difference(self):
        b = write_run(os.path.join(self.dir, 'b'), poses=POSES[:2])
        proc = self.compare(b, '--tolerance', '1e3')
        self.assertEqual(proc.returncode, 1, proc.stdout)
        self.assertIn('1 stamps in one run only', proc.stdout)

    def test_differing_counter_is_printed_and_fails(self):
        stats = dict(STATS, counters=dict(STATS['counters'], obs_gated=5))
        proc = self.compare(write_run(os.path.join(self.dir, 'b'), stats=stats))
        self.assertEqual(proc.returncode, 1, proc.stdout)
        self.assertIn('counter counters/obs_gated differs: 4 vs 5', proc.stdout)

    def test_missing_file_is_an_error(self):
        proc = self.compare(os.path.join(self.dir, 'absent'))
        self.assertEqual(proc.returncode, 2)
        self.assertIn('compare_runs:', proc.stderr)


if __name__ == '__main__':
    unittest.main()
