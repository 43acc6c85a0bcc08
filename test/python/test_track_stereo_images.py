"""track_stereo_images on a small rendered drive: the npz is a complete course dataset (loads with
the package's validator), its twist matches the ground truth within the requested noise, and
play_stereo_images.py writes the same drive as a bag; 16-bit images give the 8-bit images'
tracks."""
import os
import re
import subprocess
import unittest

import cv2
import numpy as np

import ekf_test_paths as paths
from ekf_vislam_tools import dataset, stereo_images

FRAMES = 30


def tool(name):
    """The built executable: the sourced workspace's devel space, else <repo>/build."""
    roots = [p for p in os.environ.get('CMAKE_PREFIX_PATH', '').split(os.pathsep) if p]
    roots.append(os.path.join(os.environ.get('EKF_VISLAM_WS', os.path.join(paths.REPO_ROOT,
                                                                             'build')), 'devel'))
    for root in roots:
        candidate = os.path.join(root, 'lib', 'ekf_vislam', name)
        if os.path.exists(candidate):
            return candidate
    raise unittest.SkipTest('%s not built' % name)


def track_args(folder, out):
    """track_stereo_images over an image folder (KITTI layout) into `out`, without --poses."""
    return [tool('track_stereo_images'), '--left', folder + '/image_left', '--right',
            folder + '/image_right', '--calib', folder + '/calib.txt', '--times',
            folder + '/times.txt', '--out', out]


def mean_observations(report):
    """The mean observations per frame that track_stereo_images printed."""
    return float(re.search(r'observations per frame: mean ([0-9.]+)', report).group(1))


class TrackStereoImagesTest(unittest.TestCase):

    @classmethod
    def setUpClass(cls):
        cls.tmp = paths.make_temp_dir(prefix='ekf_vislam_track_test_')
        cls.folder = os.path.join(cls.tmp, 'drive')
        result = paths.run_script('render_stereo_drive.py', cls.folder, '--frames', str(FRAMES))
        assert result.returncode == 0, result.stderr
        cls.npz = os.path.join(cls.tmp, 'tracks.npz')
        f = cls.folder
        cls.report = subprocess.run(
            track_args(f, cls.npz) + ['--poses', f + '/poses.txt', '--twist-noise', '0', '0',
                                      '--gyro-offset', '0', '--time-offset', '100'],
            check=True, stdout=subprocess.PIPE, universal_newlines=True).stdout

    @classmethod
    def tearDownClass(cls):
        paths.remove_dir(cls.tmp)

    def linked_copy(self, name, *files):
        """A folder NAME in the test's directory with links to `files` of the rendered drive."""
        folder = os.path.join(self.tmp, name)
        os.makedirs(folder, exist_ok=True)
        for file in files:
            target = os.path.join(folder, file)
            if not os.path.exists(target):
                os.symlink(os.path.join(self.folder, file), target)
        return folder

    def test_npz_is_a_course_dataset(self):
        d = dataset.load_dataset(self.npz)
        self.assertEqual(d.num_frames, FRAMES)
        self.assertEqual(d.image_size, (640, 192))
        self.assertAlmostEqual(d.b, 0.54, places=9)
        self.assertAlmostEqual(d.t[0], 100.0)
        observed = d.observed()
        self.assertGreaterEqual(observed.sum(axis=0).min(), 100)  # features in every frame
        F = d.features
        disparity = F[0][observed] - F[2][observed]
        self.assertGreater(disparity.min(), 0.0)
        self.assertLess(np.abs(F[1][observed] - F[3][observed]).max(), 1.0 + 1e-6)
        # Each id in one contiguous run.
        for row in observed:
            frames = np.nonzero(row)[0]
            self.assertEqual(frames[-1] - frames[0] + 1, len(frames))

    def test_tracks_against_the_exact_poses(self):
        """The rendered drive's poses and calibration are exact, so the printed track quality is
        the tracker's own error: measured 0.065 / 0.177 px at ages 1 / 5 and at least 317
        observations per frame. A renderer that smears a wall into stripes (cv2.remap saturating
        texture coordinates beyond 32767 px) gave 0.125 px and 240."""
        by_age = dict(re.findall(r'(\d+):([0-9.]+)\(n=', self.report))
        self.assertLess(float(by_age['1']), 0.1, self.report)
        self.assertLess(float(by_age['5']), 0.3, self.report)
        minimum = re.search(r'observations per frame: mean [0-9.]+, min (\d+)', self.report)
        self.assertGreaterEqual(int(minimum.group(1)), 280, self.report)

    def test_twist_is_the_ground_truth_motion(self):
        d = dataset.load_dataset(self.npz)
        folder = stereo_images.load_folder(self.folder)
        # The C++ tool and the Python player make the same vehicle frame from the poses.
        cam_T_imu = stereo_images.travel_aligned_cam_T_imu(folder.world_T_cam)
        np.testing.assert_allclose(d.cam_T_imu, cam_T_imu, atol=1e-9)
        world_T_imu = folder.world_T_cam @ cam_T_imu
        v, w = stereo_images.twist_from_poses(world_T_imu, folder.times, 0, 0, 0)
        np.testing.assert_allclose(d.v, v, atol=1e-6)
        np.testing.assert_allclose(d.w, w, atol=1e-6)
        self.assertAlmostEqual(float(np.median(d.v[0])), 8.0, delta=0.1)  # x forward, 8 m/s
        # The rendered camera looks along its travel: the camera's own axes within 0.3 degrees.
        np.testing.assert_allclose(d.cam_T_imu, stereo_images.CAM_T_IMU, atol=5e-3)

    def test_vehicle_frame_of_a_pitched_camera(self):
        """A camera pitched 1.5 degrees and turned 0.7 degrees against its travel: the frame's
        x is the travel, so a straight drive has no lateral or vertical velocity in it; no travel
        keeps the camera's axes."""
        from ekf_vislam_tools import se3
        pitch, yaw = np.radians(1.5), np.radians(0.7)
        mount = np.eye(4)
        mount[:3, :3] = se3.so3_exp(np.array([pitch, 0.0, 0.0])) @ se3.so3_exp(
            np.array([0.0, -yaw, 0.0]))
        poses = []
        for k in range(20):
            vehicle = np.eye(4)
            vehicle[:3, 3] = [0.0, 0.0, 1.2 * k]  # straight along the world's z
            poses.append(vehicle @ mount)
        cam_T_imu = stereo_images.travel_aligned_cam_T_imu(np.array(poses))
        world_T_imu = np.array(poses) @ cam_T_imu
        v, _ = stereo_images.twist_from_poses(world_T_imu, 0.1 * np.arange(20), 0, 0, 0)
        np.testing.assert_allclose(v[0], 12.0, atol=1e-9)
        np.testing.assert_allclose(v[1:], 0.0, atol=1e-9)
        R = cam_T_imu[:3, :3]
        np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-12)
        self.assertAlmostEqual(np.linalg.det(R), 1.0, places=12)
        # The camera's axes would see the pitch as vertical velocity (12 m/s x sin 1.5 degrees).
        v_cam, _ = stereo_images.twist_from_poses(
            np.array(poses) @ stereo_images.CAM_T_IMU, 0.1 * np.arange(20), 0, 0, 0)
        self.assertGreater(np.abs(v_cam[2]).min(), 0.25)
        np.testing.assert_array_equal(
            stereo_images.travel_aligned_cam_T_imu(np.array([poses[0]] * 5)),
            stereo_images.CAM_T_IMU)

    def test_predict_with_twist(self):
        """The exact twist's prediction starts the KLT nearer its result: the same drive, tracked
        as well (features in every frame, the same twist in the npz), and it needs --poses."""
        f, out = self.folder, os.path.join(self.tmp, 'predicted.npz')
        args = track_args(f, out) + ['--twist-noise', '0', '0', '--gyro-offset', '0',
                                     '--time-offset', '100', '--predict-with-twist']
        refused = subprocess.run(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                 universal_newlines=True)
        self.assertEqual(refused.returncode, 2)
        self.assertIn('--predict-with-twist needs --poses', refused.stderr)
        subprocess.run(args + ['--poses', f + '/poses.txt'], check=True, stdout=subprocess.PIPE)
        d, reference = dataset.load_dataset(out), dataset.load_dataset(self.npz)
        self.assertGreaterEqual(d.observed().sum(axis=0).min(), 100)
        np.testing.assert_array_equal(d.v, reference.v)
        self.assertFalse(np.array_equal(d.features, reference.features))

    def test_exposure_changes(self):
        """exposure_variant.py brightens and darkens every frame (both cameras by up to 15 %, the
        right one by up to 10 % more): with the exposure compensation the tracks hold as on the
        unchanged drive; without it fewer tracks last (measured on this 30-frame drive: 339.07
        against 202.03 observations per frame, and 339.10 unchanged)."""
        varied = os.path.join(self.tmp, 'exposure')
        result = paths.run_script('exposure_variant.py', self.folder, varied, '--right-jitter',
                                  '0.1', '--seed', '1')
        self.assertEqual(result.returncode, 0, result.stderr)
        off = os.path.join(self.tmp, 'off.yaml')
        with open(off, 'w') as f:
            f.write('klt:\n  exposure_compensation: false\n')
        means = []
        for config in ([], ['--config', off]):
            report = subprocess.run(
                track_args(varied, os.path.join(self.tmp, 'exposure.npz')) +
                ['--poses', varied + '/poses.txt'] + config,
                check=True, stdout=subprocess.PIPE, universal_newlines=True).stdout
            means.append(mean_observations(report))
        unchanged = mean_observations(self.report)
        self.assertGreater(means[0], 0.95 * unchanged, means)
        self.assertLess(means[1], 0.8 * unchanged, means)

    def test_16_bit_images(self):
        """A 12-bit camera's images as 16-bit png, values from bit 0 up (each 8-bit level times 16
        plus low bits that round away): the 8-bit images' tracks exactly, 12 significant bits read
        from the images; with ros/image_bits 16 in --config, the images taken as 16 bits wide
        (gray levels 0-15) track next to nothing."""
        deep = self.linked_copy('deep', 'calib.txt', 'times.txt', 'poses.txt')
        rng = np.random.default_rng(2)
        for side in ('image_left', 'image_right'):
            os.makedirs(os.path.join(deep, side), exist_ok=True)
            for name in sorted(os.listdir(os.path.join(self.folder, side))):
                image = cv2.imread(os.path.join(self.folder, side, name), cv2.IMREAD_GRAYSCALE)
                values = image.astype(np.uint16) * 16 + rng.integers(0, 8, image.shape)
                cv2.imwrite(os.path.join(deep, side, name), values.astype(np.uint16))
        args = ['--poses', deep + '/poses.txt', '--twist-noise', '0', '0', '--gyro-offset', '0',
                '--time-offset', '100']
        npz = os.path.join(self.tmp, 'deep.npz')
        result = subprocess.run(track_args(deep, npz) + args, check=True, stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, universal_newlines=True)
        self.assertIn('16-bit images: value / 16 tracked (12 significant bits, read from the '
                      'images)', result.stderr)
        np.testing.assert_array_equal(np.load(npz)['features'], np.load(self.npz)['features'])
        wide = os.path.join(self.tmp, 'wide.yaml')
        with open(wide, 'w') as f:
            f.write('ros:\n  image_bits: 16\n')
        report = subprocess.run(track_args(deep, npz) + args + ['--config', wide], check=True,
                                stdout=subprocess.PIPE, universal_newlines=True).stdout
        self.assertLess(mean_observations(report), 0.2 * mean_observations(self.report))

    def test_image_variants(self):
        """image_variant.py makes other regimes of the drive with calibration, times and poses to
        match, so the tracks hold against the exact poses as on the drive itself. Measured at ages 1
        / 5: mirrored (images flipped and exchanged) 0.075 / 0.190 px; reversed at half the frame
        rate and scaled by 0.75, 0.039 / 0.114; reversed, 0.036 / 0.062; the drive itself 0.075 /
        0.185; stopped 5 frames at its frame 10, 0.053 / 0.140. Mirrored with the poses left as they
        were: 2.31 px at age 1; with cx off by a pixel: 0.101 px. Reversed, the image contracts and
        the tracks come together: 662.33 observations per frame against the forward drive's 340.70,
        and 916.87 without ending the tracks that come near older ones."""
        for name, options in (('mirror', ['--mirror']),
                              ('reverse', ['--reverse', '--step', '2', '--scale', '0.75']),
                              ('backwards', ['--reverse']),
                              ('stop', ['--hold', '10:5'])):
            varied = os.path.join(self.tmp, name)
            result = paths.run_script('image_variant.py', self.folder, varied, *options)
            self.assertEqual(result.returncode, 0, result.stderr)
            times = np.loadtxt(os.path.join(varied, 'times.txt'))
            self.assertTrue(np.all(np.diff(times) > 0), name)
            expected = {'reverse': FRAMES // 2, 'stop': FRAMES + 5}.get(name, FRAMES)
            self.assertEqual(len(times), expected, name)
            report = subprocess.run(
                track_args(varied, os.path.join(self.tmp, name + '.npz')) +
                ['--poses', varied + '/poses.txt'],
                check=True, stdout=subprocess.PIPE, universal_newlines=True).stdout
            by_age = dict(re.findall(r'(\d+):([0-9.]+)\(n=', report))
            self.assertLess(float(by_age['1']), 0.1, name + report)
            self.assertLess(float(by_age['5']), 0.3, name + report)
            if name == 'backwards':
                self.assertLess(mean_observations(report), 2.3 * mean_observations(self.report),
                                report)

    def test_a_right_image_turned_against_the_left(self):
        """The rig check reads the right image's roll from the rows of the left-right matches:
        about 0 on the exact rendered rig, the made roll on a copy whose right images are turned
        (image_variant.py --right-roll), with a warning once the rows at the side edge lie 0.75
        px apart (the row tolerance 1 px). Measured: 0.0012 (the drive), 0.3053 and -0.3013
        degrees (turned 0.3 either way; 1.70 px at the edge of this 640-px image)."""
        roll = re.compile(r"right image's roll (-?[0-9.]+) degrees")
        self.assertLess(abs(float(roll.search(self.report).group(1))), 0.01, self.report)
        for degrees in (0.3, -0.3):
            varied = os.path.join(self.tmp, 'roll%g' % degrees)
            result = paths.run_script('image_variant.py', self.folder, varied, '--right-roll',
                                      str(degrees))
            self.assertEqual(result.returncode, 0, result.stderr)
            result = subprocess.run(track_args(varied, varied + '.npz'), check=True,
                                    stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                    universal_newlines=True)
            self.assertAlmostEqual(float(roll.search(result.stdout).group(1)), degrees,
                                   delta=0.02, msg=result.stdout)
            self.assertIn('turned 0.3', result.stderr)
            self.assertIn('clockwise' if degrees > 0 else 'anticlockwise', result.stderr)

    def test_masks(self):
        """mask/left and mask/right (image files, zero = no feature): no left point on the masked
        bottom rows, no right point on the masked left columns; an unreadable file stops the tool
        naming key and file."""
        left_mask = np.full((192, 640), 255, np.uint8)
        left_mask[144:, :] = 0
        right_mask = np.full((192, 640), 255, np.uint8)
        right_mask[:, :100] = 0
        files = {}
        for name, mask in (('left', left_mask), ('right', right_mask)):
            files[name] = os.path.join(self.tmp, 'mask_%s.png' % name)
            self.assertTrue(cv2.imwrite(files[name], mask))
        config = os.path.join(self.tmp, 'masks.yaml')
        with open(config, 'w') as f:
            f.write('mask:\n  left: "%s"\n  right: "%s"\n' % (files['left'], files['right']))
        out = os.path.join(self.tmp, 'masked.npz')
        subprocess.run(track_args(self.folder, out) + ['--config', config], check=True,
                       stdout=subprocess.PIPE)
        F, G = np.load(out)['features'], np.load(self.npz)['features']
        seen, seen_free = F[0] >= 0, G[0] >= 0
        self.assertEqual(int(np.sum(np.round(F[1][seen]) >= 144)), 0)
        self.assertEqual(int(np.sum(np.round(F[2][seen]) < 100)), 0)
        self.assertGreater(int(np.sum(np.round(G[1][seen_free]) >= 144)), 100)
        self.assertGreater(seen.sum(), 0.5 * seen_free.sum())
        with open(config, 'w') as f:
            f.write('mask:\n  left: "%s"\n' % os.path.join(self.tmp, 'no_such_mask.png'))
        refused = subprocess.run(track_args(self.folder, out) + ['--config', config],
                                 stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                 universal_newlines=True)
        self.assertEqual(refused.returncode, 2)
        self.assertIn("'mask/left': cannot open", refused.stderr)

    def test_first_frame(self):
        """--first-frame N starts at frame N: images, times and the poses' twist from there."""
        f, out = self.folder, os.path.join(self.tmp, 'from5.npz')
        args = track_args(f, out) + ['--poses', f + '/poses.txt', '--twist-noise', '0', '0',
                                     '--gyro-offset', '0', '--time-offset', '100']
        subprocess.run(args + ['--first-frame', '5'], check=True, stdout=subprocess.PIPE)
        d, full = dataset.load_dataset(out), dataset.load_dataset(self.npz)
        self.assertEqual(d.num_frames, FRAMES - 5)
        np.testing.assert_allclose(d.t, full.t[5:])
        np.testing.assert_allclose(d.w[:, 1:], full.w[:, 6:], atol=1e-6)
        refused = subprocess.run(args + ['--first-frame', str(FRAMES - 1)], stdout=subprocess.PIPE,
                                 stderr=subprocess.PIPE, universal_newlines=True)
        self.assertEqual(refused.returncode, 2)
        self.assertIn('leaves fewer than 2', refused.stderr)

    def test_a_rate_limit_takes_the_pairs_of_a_slower_camera(self):
        """input/max_rate_hz 4 on the 10 Hz drive tracks every second pair (a pair 0.2 s after the
        last tracked one passes 0.75 / 4 s, one 0.1 s after does not): the features are those of
        the same drive recorded at 5 Hz (image_variant.py --step 2) bit for bit, and its twist and
        ground truth are those of the pairs tracked."""
        config = os.path.join(self.tmp, 'rate4.yaml')
        with open(config, 'w') as out:
            out.write('input:\n  max_rate_hz: 4.0\n')
        limited, slower = os.path.join(self.tmp, 'rate4.npz'), os.path.join(self.tmp, 'step2.npz')
        report = subprocess.run(
            track_args(self.folder, limited) + ['--poses', self.folder + '/poses.txt', '--config',
                                                config],
            check=True, stdout=subprocess.PIPE, universal_newlines=True).stdout
        self.assertIn('input/max_rate_hz 4: %d of %d pairs skipped' % (FRAMES // 2, FRAMES), report)
        varied = os.path.join(self.tmp, 'step2')
        result = paths.run_script('image_variant.py', self.folder, varied, '--step', '2')
        self.assertEqual(result.returncode, 0, result.stderr)
        subprocess.run(track_args(varied, slower) + ['--poses', varied + '/poses.txt'], check=True,
                       stdout=subprocess.PIPE)
        a, b = np.load(limited), np.load(slower)
        self.assertEqual(a['time_stamps'].shape, (1, FRAMES // 2))
        np.testing.assert_array_equal(a['time_stamps'], b['time_stamps'])
        np.testing.assert_array_equal(a['features'], b['features'])
        np.testing.assert_allclose(a['linear_velocity'], b['linear_velocity'], atol=1e-6)
        self.assertEqual(len(np.loadtxt(limited[:-4] + '_groundtruth.tum')), FRAMES // 2)

    def test_groundtruth_vs_images(self):
        """groundtruth_vs_images.py: the rendered drive's exact poses agree with its images; the
        same poses with a 0.3 degree yaw slipped in between frames 9 and 10 are caught there."""
        import json
        from ekf_vislam_tools import se3
        exact = os.path.join(self.tmp, 'exact.json')
        result = paths.run_script('groundtruth_vs_images.py', self.folder, '--json', exact)
        self.assertEqual(result.returncode, 0, result.stderr)
        with open(exact) as f:
            difference = np.array(json.load(f)['difference_deg'])
        self.assertEqual(difference.shape, (FRAMES - 1, 3))
        size = np.linalg.norm(difference, axis=1)
        self.assertLess(np.median(size), 0.2)  # the fit's own precision on 640 px images: 0.108
        # A copy whose poses from frame 10 on are turned 0.3 degrees about the camera's y.
        slipped = self.linked_copy('slipped', 'image_left', 'image_right', 'calib.txt', 'times.txt')
        poses = stereo_images.read_poses(os.path.join(self.folder, 'poses.txt'))
        turn = np.eye(4)
        turn[:3, :3] = se3.so3_exp(np.array([0.0, np.radians(0.3), 0.0]))
        poses[10:] = poses[10:] @ turn
        np.savetxt(os.path.join(slipped, 'poses.txt'), poses[:, :3, :].reshape(-1, 12))
        out = os.path.join(self.tmp, 'slipped.json')
        result = paths.run_script('groundtruth_vs_images.py', slipped, '--json', out)
        self.assertEqual(result.returncode, 0, result.stderr)
        with open(out) as f:
            slipped_difference = np.array(json.load(f)['difference_deg'])
        self.assertAlmostEqual(slipped_difference[9, 1], difference[9, 1] + 0.3, delta=0.02)
        np.testing.assert_allclose(slipped_difference[:9], difference[:9])
        self.assertIn('median size', result.stdout)

    def test_a_calibration_that_is_not_rectified_is_refused(self):
        # P1's principal point half a pixel right of P0's: the estimator's rule refuses it, and
        # so does the tracker (it used to read P0's alone).
        folder = self.linked_copy('unrectified', 'image_left', 'image_right', 'times.txt')
        with open(os.path.join(self.folder, 'calib.txt')) as f:
            lines = f.read().splitlines()
        p1 = lines[1].split()
        p1[3] = repr(float(p1[3]) + 0.5)  # P1[0,2]: label, then the row-major numbers
        lines[1] = ' '.join(p1)
        with open(os.path.join(folder, 'calib.txt'), 'w') as f:
            f.write('\n'.join(lines) + '\n')
        result = subprocess.run(track_args(folder, os.path.join(self.tmp, 'unrectified.npz')),
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                universal_newlines=True)
        self.assertEqual(result.returncode, 2, result.stdout)
        self.assertIn('P0 and P1', result.stderr)
        self.assertIn('rectified', result.stderr)

    def test_cameras_pick_the_projections_of_calib_txt(self):
        # The drive's P0 and P1 written as P2 and P3 beside two other projections: --cameras 2 3
        # tracks as the drive does; without P2 and P3 the run is refused, naming them.
        folder = self.linked_copy('cameras', 'image_left', 'image_right', 'times.txt',
                                  'poses.txt')
        with open(os.path.join(self.folder, 'calib.txt')) as f:
            p0, p1 = [line.split(None, 1)[1] for line in f.read().splitlines()[:2]]
        gray_left = '500 0 300 0 0 500 100 0 0 0 1 0'
        gray_right = '500 0 300 -100 0 500 100 0 0 0 1 0'
        with open(os.path.join(folder, 'calib.txt'), 'w') as f:
            f.write('P0: %s\nP1: %s\nP2: %s\nP3: %s\n' % (gray_left, gray_right, p0, p1))
        out = os.path.join(self.tmp, 'cameras.npz')
        report = subprocess.run(
            track_args(folder, out) + ['--poses', folder + '/poses.txt', '--twist-noise', '0',
                                       '0', '--gyro-offset', '0', '--time-offset', '100',
                                       '--cameras', '2', '3'],
            check=True, stdout=subprocess.PIPE, universal_newlines=True).stdout
        with np.load(self.npz) as drive, np.load(out) as picked:
            np.testing.assert_array_equal(picked['features'], drive['features'])
            np.testing.assert_array_equal(picked['K'], drive['K'])
        self.assertEqual(re.search(r'by age:.*', report).group(0),
                         re.search(r'by age:.*', self.report).group(0))
        refused = subprocess.run(track_args(self.folder, out) + ['--cameras', '2', '3'],
                                 stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                 universal_newlines=True)
        self.assertEqual(refused.returncode, 2)
        self.assertIn('P2 and P3', refused.stderr)

    def test_a_folder_in_kittis_own_layout(self):
        # image_0/ and image_1/ (KITTI's names) found by --folder and by the Python tools.
        folder = os.path.join(self.tmp, 'kitti_layout')
        os.makedirs(folder)
        for link, target in (('image_0', 'image_left'), ('image_1', 'image_right'),
                             ('calib.txt', 'calib.txt'), ('times.txt', 'times.txt')):
            os.symlink(os.path.join(self.folder, target), os.path.join(folder, link))
        out = os.path.join(self.tmp, 'kitti_layout.npz')
        subprocess.run([tool('track_stereo_images'), '--folder', folder, '--out', out,
                        '--time-offset', '100'], check=True, stdout=subprocess.PIPE)
        with np.load(self.npz) as drive, np.load(out) as found:
            np.testing.assert_array_equal(found['features'], drive['features'])
            self.assertNotIn('linear_velocity', found.files)  # --poses is never implied
        loaded = stereo_images.load_folder(folder)
        self.assertEqual([os.path.basename(p) for p in loaded.left],
                         sorted(os.listdir(os.path.join(self.folder, 'image_left'))))
        self.assertEqual(os.path.dirname(loaded.right[0]), os.path.join(folder, 'image_1'))
        self.assertIsNone(loaded.world_T_cam)
        missing = subprocess.run([tool('track_stereo_images'), '--folder', self.tmp, '--out', out],
                                 stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                 universal_newlines=True)
        self.assertEqual(missing.returncode, 2)
        self.assertIn(os.path.join(self.tmp, 'image_0'), missing.stderr)
        # Poses kept apart (KITTI's poses/NN.txt) give the bag its twist.
        bag = os.path.join(self.tmp, 'kitti_layout.bag')
        for poses, twists in ((None, 0), (os.path.join(self.folder, 'poses.txt'), FRAMES)):
            result = paths.run_script('play_stereo_images.py', folder, '--bag', bag,
                                      *(['--poses', poses] if poses else []))
            self.assertEqual(result.returncode, 0, result.stderr)
            import rosbag
            with rosbag.Bag(bag) as b:
                counts = b.get_type_and_topic_info().topics
            self.assertEqual(counts['/stereo/left/image_rect'].message_count, FRAMES)
            twist = counts.get('/imu/twist')
            self.assertEqual(twist.message_count if twist else 0, twists)

    def test_columns_shared_after_a_gap_hold_the_same_tracks(self):
        # --reuse-gap 3: fewer columns, each holding runs of consecutive frames at least 3 frames
        # apart, and the same observations as one column per id.
        out = os.path.join(self.tmp, 'shared_columns.npz')
        subprocess.run(track_args(self.folder, out) +
                       ['--poses', self.folder + '/poses.txt', '--twist-noise', '0', '0',
                        '--gyro-offset', '0', '--time-offset', '100', '--reuse-gap', '3'],
                       check=True, stdout=subprocess.PIPE)
        with np.load(self.npz) as fresh, np.load(out) as shared:
            F, S = fresh['features'], shared['features']
        self.assertLess(S.shape[1], F.shape[1] * 0.75)
        # Marked, so that dataset_to_bag.py lists a frame's tracks by age.
        self.assertTrue(dataset.load_dataset(out, fix_twist_axes=False).columns_shared)
        self.assertFalse(dataset.load_dataset(self.npz, fix_twist_axes=False).columns_shared)

        def runs(features):
            observed = features[0] >= 0
            found = []
            for j in range(features.shape[1]):
                frames = np.flatnonzero(observed[j])
                for run in np.split(frames, np.flatnonzero(np.diff(frames) != 1) + 1):
                    if run.size:
                        found.append((run[0], run[-1], tuple(features[:, j, run[0]])))
            return found

        shared_runs = runs(S)
        self.assertEqual(sorted(shared_runs), sorted(runs(F)))
        observed = S[0] >= 0
        for j in range(S.shape[1]):
            frames = np.flatnonzero(observed[j])
            gaps = np.diff(frames)
            self.assertTrue(np.all((gaps == 1) | (gaps > 3)), gaps)

    def test_bag_of_images(self):
        bag = os.path.join(self.tmp, 'drive.bag')
        result = paths.run_script('play_stereo_images.py', self.folder, '--bag', bag)
        self.assertEqual(result.returncode, 0, result.stderr)
        self.assertIn('%d stereo pairs' % FRAMES, result.stdout)
        import rosbag
        with rosbag.Bag(bag) as b:
            counts = b.get_type_and_topic_info().topics
        self.assertEqual(counts['/stereo/left/image_rect'].message_count, FRAMES)
        self.assertEqual(counts['/imu/twist'].message_count, FRAMES)


if __name__ == '__main__':
    unittest.main()
