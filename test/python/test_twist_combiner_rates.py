"""A gyro faster than the wheel odometry, end to end: a simulated 100 Hz drive written as a
100 Hz gyro, a 20 Hz wheel odometry of base_link and 10 Hz feature frames
(dataset_to_bag.py --twist-type imu_odometry --wheel-every 5 --features-every 10), then
vislam_offline, against the same drive with its 100 Hz twist. The combined twists carry each
sensor's noise at its own density; without that, the interpolated wheel velocity read as nearly
noise-free (this drive: position NEES 287.8 and ATE 0.433 m then; 2.85 and 0.084 m now, against
2.86 and 0.090 m with the 100 Hz twist)."""
import json
import os
import subprocess
import unittest

import ekf_test_paths as paths
from ekf_vislam_tools import package, simulator

TO_BAG = os.path.join(paths.SCRIPTS_DIR, 'dataset_to_bag.py')
EVALUATE = os.path.join(paths.SCRIPTS_DIR, 'evaluate.py')
# This drive gives NEES 2.85 and 0.93x the twist's ATE (the test prints them); the limits leave
# margin and fail the uncorrected combiner by far (287.8, 4.8x).
NEES_LIMIT = 12.0
ATE_RATIO_LIMIT = 1.6


class TwistCombinerRatesTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.offline = package.vislam_offline_path()
        if cls.offline is None:
            raise unittest.SkipTest('vislam_offline not built')
        cls.tmp = paths.make_temp_dir()
        cls.addClassCleanup(paths.remove_dir, cls.tmp)
        sim = simulator.simulate(4, frames=2000, rate_hz=100.0, track_loss=0.005)
        cls.groundtruth = simulator.write_outputs(sim, os.path.join(cls.tmp, 'sim'))
        cls.results = {name: cls.run_offline(name, *args) for name, args in (
            ('twist', ('--features-every', '10')),
            ('combined', ('--twist-type', 'imu_odometry', '--wheel-every', '5',
                          '--features-every', '10')))}

    @classmethod
    def run_offline(cls, name, *to_bag_args):
        """-> (ATE m, mean position NEES, stats of the run) of vislam_offline on the drive."""
        bag = os.path.join(cls.tmp, name + '.bag')
        subprocess.run([paths.PYTHON, TO_BAG, cls.groundtruth['npz'], bag] + list(to_bag_args),
                       check=True, capture_output=True)
        out = os.path.join(cls.tmp, name)
        subprocess.run([cls.offline, '--bag', bag, '--out', out], check=True,
                       capture_output=True)
        evaluation = os.path.join(cls.tmp, name + '_eval')
        subprocess.run([paths.PYTHON, EVALUATE, '--estimate', os.path.join(out, 'trajectory.tum'),
                        '--groundtruth', cls.groundtruth['groundtruth'], '--out', evaluation],
                       check=True, capture_output=True)
        with open(os.path.join(evaluation, 'metrics.json')) as f:
            result, = json.load(f)['estimates'].values()
        with open(os.path.join(out, 'stats.json')) as f:
            stats = json.load(f)
        return result['ate_rmse_m'], result['nees_position']['mean'], stats

    def test_every_gyro_sample_is_a_twist(self):
        stats = self.results['combined'][2]
        self.assertEqual(stats['twist_combiner_gyro_samples'], 2000)
        self.assertEqual(stats['twist_combiner_wheel_samples'], 400)
        self.assertEqual(stats['twist_combiner_velocity_held'], 0)
        self.assertEqual(stats['frames'], 200)

    def test_the_covariance_stays_honest_and_the_accuracy_close_to_the_full_rate_twist(self):
        twist_ate, twist_nees, _ = self.results['twist']
        combined_ate, combined_nees, _ = self.results['combined']
        print('100 Hz twist: ATE %.3f m, position NEES %.2f; 100 Hz gyro + 20 Hz wheel: ATE %.3f '
              'm, NEES %.2f' % (twist_ate, twist_nees, combined_ate, combined_nees))
        self.assertLess(combined_nees, NEES_LIMIT)
        self.assertLess(combined_ate, ATE_RATIO_LIMIT * twist_ate)
