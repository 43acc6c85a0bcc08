"""vislam_offline's warnings about the regime: few observations updating the filter
(sparseObservationsHint), a road tilt beyond its prior (roadTiltHint), an accelerometer whose
samples are refused (accelerometerHint), stereo features from swapped or unrectified images
(featureGeometryHint), a disparity offset the observations show (disparityOffsetHint) and a
camera_info that changes during the bag."""
import json
import os
import subprocess
import unittest

import rosbag

import ekf_test_paths as paths
from ekf_vislam_tools import package, simulator

TO_BAG = os.path.join(paths.SCRIPTS_DIR, 'dataset_to_bag.py')
WARNING = 'observations per frame updated the filter'
TILT_WARNING = "the road's tilt is estimated at"
SWAP_WARNING = 'are the left and right images (or u_left and u_right) swapped?'
ROW_WARNING = 'had left and right rows further apart than limits/max_row_difference_px'
INFO_WARNING = 'camera_info message(s) differ from the first of their camera: ignored'
OFFSET_WARNING = "px too large against the twist's motion"
ACCURATE_TWIST = dict(velocity_noise=0.05, gyro_noise=0.005, gyro_bias=[0.001])


class RegimeWarningsTest(unittest.TestCase):
    def setUp(self):
        self.offline = package.vislam_offline_path()
        if self.offline is None:
            self.skipTest('vislam_offline not built')
        self.tmp = paths.make_temp_dir(self)

    def run_offline(self, name, target_obs, mode='slam', seed=4, frames=200, change=None,
                    change_bag=None, **options):
        """Simulates a drive tracking about target_obs features per frame (its arrays passed
        through change, its bag through change_bag(in, out), when given); returns the run's
        stderr and stats.json."""
        arrays = simulator.dataset_arrays(simulator.simulate(seed, frames=frames,
                                                             target_obs=target_obs, **options))
        if change is not None:
            change(arrays)
        npz = paths.write_npz(self.tmp, name + '.npz', arrays)
        bag = os.path.join(self.tmp, name + '.bag')
        subprocess.run([paths.PYTHON, TO_BAG, npz, bag], check=True, capture_output=True)
        if change_bag is not None:
            change_bag(bag, bag + '.changed.bag')
            bag += '.changed.bag'
        out = os.path.join(self.tmp, name + '_' + mode)
        proc = subprocess.run([self.offline, '--bag', bag, '--mode', mode, '--out', out],
                              capture_output=True, text=True)
        self.assertEqual(proc.returncode, 0, proc.stderr)
        with open(os.path.join(out, 'stats.json')) as f:
            return proc.stderr, json.load(f)

    def test_few_observations_per_frame_are_named(self):
        stderr, stats = self.run_offline('sparse', target_obs=3)
        self.assertGreater(stats['observations_per_frame'], 0.5)
        self.assertLess(stats['observations_per_frame'], 8.0)
        self.assertIn(WARNING, stderr)
        self.assertIn('covariance', stderr)
        # Dead reckoning updates nothing, mapping leaves the pose to the twist: no warning.
        stderr, stats = self.run_offline('sparse', target_obs=3, mode='deadreckoning')
        self.assertEqual(stats['observations_per_frame'], 0.0)
        self.assertNotIn(WARNING, stderr)
        stderr, stats = self.run_offline('sparse', target_obs=3, mode='mapping')
        self.assertGreater(stats['observations_per_frame'], 0.5)
        self.assertNotIn(WARNING, stderr)

    def test_an_accelerometer_with_gravity_removed_is_named(self):
        # A driver that publishes the acceleration without gravity: every sample refused,
        # counted, and the run says what to check; the raw specific force is used silently.
        stderr, stats = self.run_offline('accel', target_obs=70, accel_noise=0.05)
        self.assertEqual(stats['counters']['accel_used'], 200)
        self.assertGreater(stats['counters']['gravity_update'], 10)
        self.assertNotIn('accelerometer samples refused', stderr)

        def remove_gravity(arrays):
            arrays['specific_force'] = arrays['specific_force'] - [[0.0], [0.0], [9.80665]]
        stderr, stats = self.run_offline('no_gravity', target_obs=70, accel_noise=0.05,
                                         change=remove_gravity)
        self.assertEqual(stats['counters']['accel_implausible'], 200)
        self.assertEqual(stats['counters']['gravity_update'], 0)
        self.assertIn('200 of 200 accelerometer samples refused', stderr)

    def test_swapped_or_unrectified_features_are_named(self):
        def observed(change_rows):
            """A change of the observed columns of features (rows uL, vL, uR, vR)."""
            def change(arrays):
                features = arrays['features'].copy()
                change_rows(features, features[0] >= 0)
                arrays['features'] = features
            return change

        # A feature source with its left and right images swapped: every disparity negative.
        def swap(f, seen):
            f[0][seen], f[2][seen] = f[2][seen].copy(), f[0][seen].copy()
        stderr, stats = self.run_offline('swapped', target_obs=70, change=observed(swap))
        self.assertGreater(stats['counters']['observation_disparity'], 5000)
        self.assertIn(SWAP_WARNING, stderr)
        self.assertNotIn(ROW_WARNING, stderr)

        # Its right image's rows 8 px below the left one's (beyond max_row_difference_px, 5).
        def lower_right_rows(f, seen):
            f[3][seen] += 8.0
        stderr, stats = self.run_offline('rows', target_obs=70, change=observed(lower_right_rows))
        self.assertGreater(stats['counters']['observation_row_mismatch'], 5000)
        self.assertIn(ROW_WARNING, stderr)
        self.assertNotIn(SWAP_WARNING, stderr)

    def test_dense_tracks_say_nothing(self):
        stderr, stats = self.run_offline('dense', target_obs=70)
        self.assertGreater(stats['observations_per_frame'], 20.0)
        self.assertNotIn(WARNING, stderr)
        self.assertNotIn(SWAP_WARNING, stderr)
        self.assertNotIn(ROW_WARNING, stderr)
        self.assertLess(stats['road_tilt_deg'], 3.0)
        self.assertNotIn(TILT_WARNING, stderr)

    def test_a_road_steeper_than_the_prior_is_named(self):
        # Roll and pitch up to 4 and 10 degrees: this drive ends 10.7 degrees from the start's
        # level, beyond three times the 2.9-degree prior, and the estimate follows it.
        stderr, stats = self.run_offline('steep', target_obs=70, seed=3, frames=400,
                                         roll_amplitude=4.0, pitch_amplitude=10.0)
        self.assertGreater(stats['road_tilt_deg'], 8.6)
        self.assertIn(TILT_WARNING, stderr)
        self.assertIn('tilt_sigma', stderr)

    def test_a_disparity_offset_the_observations_show_is_counted_and_named(self):
        # Every disparity 1 px too large, a good twist: the updates' innovations read the offset
        # and the counted sigma (0.1 px configured) grows to it; the same drive with exact
        # disparities reads little and counts 0.1 px.
        for offset in (1.0, 0.0):
            stderr, stats = self.run_offline('offset%g' % offset, target_obs=70, seed=2,
                                             frames=600, disparity_offset=offset,
                                             **ACCURATE_TWIST)
            self.assertAlmostEqual(stats['disparity_offset_shown_px'], offset, delta=0.2)
            if offset:
                self.assertGreater(stats['disparity_offset_sigma_px'], 0.6)
                self.assertIn(OFFSET_WARNING, stderr)
                self.assertIn('disparity_offset_counted_sigma (0.10 px)', stderr)
            else:
                self.assertAlmostEqual(stats['disparity_offset_sigma_px'], 0.1, delta=0.01)
                self.assertNotIn('disparity_offset_counted_sigma', stderr)

    def test_a_changed_camera_info_is_counted_and_ignored(self):
        stderr, stats = self.run_offline('info', target_obs=70)
        self.assertEqual(stats['camera_info_changed'], 0)
        self.assertNotIn(INFO_WARNING, stderr)

        def change_one_left_info(bag_in, bag_out):
            """The 50th left camera_info with a focal length 5 px larger."""
            with rosbag.Bag(bag_in) as source, rosbag.Bag(bag_out, 'w') as target:
                left = 0
                for topic, msg, t in source.read_messages():
                    if topic == '/stereo/left/camera_info':
                        left += 1
                        if left == 50:
                            msg.P = list(msg.P)
                            msg.P[0] += 5.0
                    target.write(topic, msg, t)
        stderr, stats = self.run_offline('info_changed', target_obs=70,
                                         change_bag=change_one_left_info)
        self.assertEqual(stats['camera_info_changed'], 1)
        self.assertIn('1 ' + INFO_WARNING, stderr)
        # The calibration of the first pair, as without the change: the same trajectory.
        with open(os.path.join(self.tmp, 'info_slam', 'trajectory.tum')) as a, \
                open(os.path.join(self.tmp, 'info_changed_slam', 'trajectory.tum')) as b:
            self.assertEqual(a.read(), b.read())


if __name__ == '__main__':
    unittest.main()
