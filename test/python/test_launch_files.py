"""The launch files' wiring, as roslaunch resolves it (no master needed): which nodes start with
which parameters for each main argument, and every launch file valid (roslaunch-check)."""
import os
import subprocess
import unittest

import yaml

import ekf_test_paths

LAUNCH_DIR = os.path.join(ekf_test_paths.REPO_ROOT, 'launch')


def roslaunch(*args):
    result = subprocess.run(['roslaunch'] + list(args), stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, universal_newlines=True, timeout=120)
    if result.returncode != 0:
        raise AssertionError('roslaunch %s failed:\n%s%s' % (' '.join(args), result.stdout,
                                                            result.stderr))
    return result.stdout


def params(launch, *args):
    return yaml.safe_load(roslaunch('--dump-params', os.path.join(LAUNCH_DIR, launch), *args))


def nodes(launch, *args):
    return set(roslaunch('--nodes', os.path.join(LAUNCH_DIR, launch), *args).split())


class LaunchFileTest(unittest.TestCase):
    def test_every_launch_file_passes_roslaunch_check(self):
        check = '/usr/share/roslaunch/scripts/roslaunch-check'
        for name in sorted(os.listdir(LAUNCH_DIR)):
            result = subprocess.run(['/usr/bin/python3', check, '-i',
                                     os.path.join(LAUNCH_DIR, name), '-o', os.devnull],
                                    stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                    universal_newlines=True, timeout=120)
            self.assertEqual(result.returncode, 0, name + ':\n' + result.stdout)

    def test_the_estimator_alone_takes_a_twist(self):
        p = params('vislam.launch')
        self.assertEqual(p['/vislam/ros/twist_type'], 'twist_stamped')
        self.assertNotIn('/twist_combiner/combiner/imu_samples_per_twist', p)
        self.assertEqual(nodes('vislam.launch'), {'/vislam_manager', '/vislam'})

    def test_twist_combiner_argument_adds_the_combiner_and_sets_both_twist_types(self):
        p = params('stereo_vislam.launch', 'twist_combiner:=true', 'imu_frame:=imu_link',
                   'base_frame:=base_link')
        self.assertEqual(p['/vislam/ros/twist_type'], 'twist_with_covariance')
        self.assertEqual(p['/stereo_tracker/ros/twist_type'], 'twist_with_covariance')
        self.assertEqual(p['/twist_combiner/combiner/imu_samples_per_twist'], 1)
        self.assertEqual(p['/twist_combiner/ros/imu_frame'], 'imu_link')
        self.assertEqual(p['/vislam/ros/imu_frame'], 'imu_link')
        self.assertEqual(p['/vislam/ros/base_frame'], 'base_link')
        self.assertEqual(nodes('stereo_vislam.launch', 'twist_combiner:=true'),
                         {'/stereo_vislam_manager', '/vislam', '/twist_combiner',
                          '/stereo_tracker'})
        self.assertEqual(nodes('vislam.launch', 'twist_combiner:=true', 'standalone:=true'),
                         {'/vislam', '/twist_combiner'})


if __name__ == '__main__':
    unittest.main()
