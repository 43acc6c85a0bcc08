"""The launch files' wiring, as roslaunch resolves it (no master needed): which nodes start with
which parameters for each main argument, and every launch file valid (roslaunch-check)."""
import os
import subprocess
import unittest

import yaml
from roslaunch.config import ROSLaunchConfig
from roslaunch.xmlloader import XmlLoader

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


def node_args(launch, name, *args):
    """The command-line arguments of node `name` as the launch file resolves them (the node's
    package need not be installed)."""
    config = ROSLaunchConfig()
    XmlLoader().load(os.path.join(LAUNCH_DIR, launch), config, argv=['roslaunch'] + list(args),
                     verbose=False)
    return {node.name: node.args for node in config.nodes}[name]


def rviz_topics(path):
    """Every topic an rviz display file shows."""
    with open(path) as f:
        displays = yaml.safe_load(f)['Visualization Manager']['Displays']
    keys = ('Topic', 'Marker Topic', 'Image Topic')
    return {d[k] for d in displays for k in keys if k in d}


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

    def test_image_transport_argument_sets_the_trackers_key(self):
        self.assertEqual(params('stereo_vislam.launch')['/stereo_tracker/ros/image_transport'],
                         'raw')
        p = params('stereo_vislam.launch', 'image_transport:=compressed')
        self.assertEqual(p['/stereo_tracker/ros/image_transport'], 'compressed')

    def test_rectify_argument_sets_the_trackers_key(self):
        self.assertIs(params('stereo_vislam.launch')['/stereo_tracker/ros/rectify'], False)
        p = params('stereo_vislam.launch', 'rectify:=true')
        self.assertIs(p['/stereo_tracker/ros/rectify'], True)

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


    def test_rviz_shows_the_tracker_debug_image_with_the_stereo_launch(self):
        rviz_dir = os.path.join(ekf_test_paths.REPO_ROOT, 'rviz')
        outputs = {'/vislam/path', '/vislam/landmarks', '/vislam/odometry', '/groundtruth/path'}
        self.assertEqual(rviz_topics(os.path.join(rviz_dir, 'vislam.rviz')), outputs)
        self.assertEqual(rviz_topics(os.path.join(rviz_dir, 'stereo_vislam.rviz')),
                         outputs | {'/stereo/debug_image'})
        self.assertTrue(node_args('vislam.launch', 'rviz', 'rviz:=true').endswith(
            '/rviz/vislam.rviz'))
        self.assertTrue(node_args('stereo_vislam.launch', 'rviz', 'rviz:=true').endswith(
            '/rviz/stereo_vislam.rviz'))
        self.assertNotIn('/groundtruth_path', nodes('stereo_vislam.launch'))
        self.assertIn('/groundtruth_path', nodes('stereo_vislam.launch', 'groundtruth_path:=true'))


if __name__ == '__main__':
    unittest.main()
