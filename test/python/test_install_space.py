"""The package as installed (`scripts/check_install.sh`): the catkin install space alone, in an
environment that has seen neither the repository nor the devel space, runs the tools (the
trajectory equal to the devel space's) and every launch file's nodes and nodelets."""
import os
import subprocess
import unittest

import ekf_test_paths


class InstallSpaceTest(unittest.TestCase):
    def test_the_installed_package_runs_its_tools_and_launch_files(self):
        script = os.path.join(ekf_test_paths.SCRIPTS_DIR, 'check_install.sh')
        result = subprocess.run(['/bin/bash', script], stdout=subprocess.PIPE,
                                stderr=subprocess.STDOUT, universal_newlines=True, timeout=600)
        self.assertEqual(result.returncode, 0, result.stdout)
        self.assertIn('the installed vislam_offline\'s trajectory equals the devel space\'s',
                      result.stdout)
        self.assertIn('roslaunch ekf_vislam stereo_vislam.launch: /stereo_vislam_manager '
                      '/stereo_tracker /vislam', result.stdout)
        self.assertIn('check_install: 9 checks passed', result.stdout)


if __name__ == '__main__':
    unittest.main()
