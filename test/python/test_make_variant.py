"""scripts/make_variant.py: the accurate twist integrates back to the ground truth, the noise and
the id subset are what was asked, everything is deterministic per seed, and repeated frames are
split out."""
import os
import sys
import unittest

import numpy as np

import ekf_test_paths

sys.path.insert(0, ekf_test_paths.SOURCE_DIR)
from ekf_vislam_tools import se3, trajectory  # noqa: E402


class MakeVariantTest(unittest.TestCase):

    @classmethod
    def setUpClass(cls):
        cls.tmp, cls.prefix = ekf_test_paths.simulated_drive(cls, '--seed', 4, '--frames', 120)
        cls.gt = cls.prefix + '_groundtruth.tum'

    def variant(self, name, *args):
        out = os.path.join(self.tmp, name + '.npz')
        proc = ekf_test_paths.run_script('make_variant.py', self.prefix + '.npz', '--groundtruth',
                                         self.gt, '--out', out, *args)
        self.assertEqual(proc.returncode, 0, proc.stderr)
        with np.load(out) as data:
            return {key: data[key] for key in data.files}

    def test_noiseless_accurate_twist_integrates_to_the_groundtruth(self):
        v = self.variant('exact', '--twist', 'accurate', '--twist-noise', 0, 0,
                         '--gyro-offset', 0)
        t_gt, T_gt = trajectory.read_tum(self.gt)
        t = v['time_stamps'].ravel()
        T = T_gt[0].copy()
        worst = 0.0
        for k in range(1, t.size):
            T = T @ se3.twist_exp(v['linear_velocity'][:, k], v['rotational_velocity'][:, k],
                                  t[k] - t[k - 1])
            worst = max(worst, np.linalg.norm(T[:3, 3] - T_gt[k, :3, 3]))
        self.assertLess(worst, 1e-6)

    def test_noise_offset_and_seed(self):
        exact = self.variant('exact2', '--twist', 'accurate', '--twist-noise', 0, 0,
                             '--gyro-offset', 0)
        a = self.variant('a', '--twist', 'accurate', '--seed', 7)
        b = self.variant('b', '--twist', 'accurate', '--seed', 7)
        np.testing.assert_array_equal(a['linear_velocity'], b['linear_velocity'])
        dv = a['linear_velocity'] - exact['linear_velocity']
        dw = a['rotational_velocity'] - exact['rotational_velocity']
        self.assertAlmostEqual(np.std(dv), 0.05, delta=0.006)
        self.assertAlmostEqual(np.mean(dw), 0.001, delta=0.0006)
        self.assertAlmostEqual(np.std(dw), 0.005, delta=0.0006)

    def test_speed_scale_multiplies_the_linear_velocity_only(self):
        plain = self.variant('plain', '--twist', 'accurate', '--seed', 3)
        scaled = self.variant('scaled', '--twist', 'accurate', '--seed', 3, '--speed-scale', 1.03)
        np.testing.assert_allclose(scaled['linear_velocity'], 1.03 * plain['linear_velocity'],
                                   rtol=1e-12)
        np.testing.assert_array_equal(scaled['rotational_velocity'], plain['rotational_velocity'])
        np.testing.assert_array_equal(scaled['features'], plain['features'])
        course = self.variant('course', '--twist', 'course', '--speed-scale', 0.97)
        with np.load(self.prefix + '.npz') as data:
            np.testing.assert_allclose(course['linear_velocity'], 0.97 * data['linear_velocity'],
                                       rtol=1e-12)
        proc = ekf_test_paths.run_script('make_variant.py', self.prefix + '.npz', '--groundtruth',
                                         self.gt, '--twist', 'course', '--speed-scale', 0,
                                         '--out', os.path.join(self.tmp, 'bad.npz'))
        self.assertEqual(proc.returncode, 2)
        self.assertIn('speed scale', proc.stderr)

    def test_keep_fraction_keeps_a_seeded_subset_and_every_other_key(self):
        original = dict(np.load(self.prefix + '.npz'))
        v = self.variant('quarter', '--twist', 'course', '--keep-fraction', 0.25, '--seed', 3)
        again = self.variant('quarter2', '--twist', 'course', '--keep-fraction', 0.25, '--seed', 3)
        ids = original['features'].shape[1]
        kept = np.any(v['features'][0] != -1, axis=1)
        seen = np.any(original['features'][0] != -1, axis=1)
        self.assertLessEqual(kept.sum(), round(0.25 * ids))
        self.assertGreater(kept.sum(), 0.2 * seen.sum())
        np.testing.assert_array_equal(v['features'], again['features'])
        np.testing.assert_array_equal(v['features'][:, kept], original['features'][:, kept])
        np.testing.assert_array_equal(v['linear_velocity'], original['linear_velocity'])
        self.assertEqual(set(v), set(original))

    def test_kitti_poses_give_the_twist_of_the_tum_file(self):
        """A KITTI poses file (world_T_cam0, a line per frame) with the dataset's cam_T_imu."""
        with np.load(self.prefix + '.npz') as data:
            cam_T_imu = data['cam_T_imu']
            num_frames = data['time_stamps'].size
        _, T_gt = trajectory.read_tum(self.gt)
        self.assertEqual(len(T_gt), num_frames)
        kitti = os.path.join(self.tmp, 'poses.txt')
        world_T_cam0 = np.einsum('nij,jk->nik', T_gt, se3.inverse(cam_T_imu))
        np.savetxt(kitti, world_T_cam0[:, :3, :].reshape(-1, 12), fmt='%.12e')
        from_tum = self.variant('from_tum', '--twist', 'accurate', '--seed', 5)
        out = os.path.join(self.tmp, 'from_kitti.npz')
        proc = ekf_test_paths.run_script('make_variant.py', self.prefix + '.npz', '--groundtruth',
                                         kitti, '--out', out, '--twist', 'accurate', '--seed', 5)
        self.assertEqual(proc.returncode, 0, proc.stderr)
        with np.load(out) as from_kitti:
            for key in ('linear_velocity', 'rotational_velocity'):
                np.testing.assert_allclose(from_kitti[key], from_tum[key], atol=1e-5)

    def test_split_repeated_empties_repeats_and_gives_tracks_through_them_new_ids(self):
        original = dict(np.load(self.prefix + '.npz'))
        features = original['features']
        repeat = 40
        # Frame 40 re-publishes frame 39 (the course files' repeated frames): every track the
        # two share keeps its frame-39 coordinates; a track starting at 40 makes it no less one.
        observed = features[0] != -1
        shared = observed[:, repeat] & observed[:, repeat - 1]
        self.assertGreater(shared.sum(), 5)
        features[:, shared, repeat] = features[:, shared, repeat - 1]
        source = os.path.join(self.tmp, 'with_repeat.npz')
        np.savez(source, **original)
        out = os.path.join(self.tmp, 'split.npz')
        proc = ekf_test_paths.run_script('make_variant.py', source, '--groundtruth', self.gt,
                                         '--twist', 'course', '--split-repeated', '--out', out)
        self.assertEqual(proc.returncode, 0, proc.stderr)
        self.assertIn('1 repeated frames emptied', proc.stdout)
        split = np.load(out)['features']
        self.assertTrue(np.all(split[:, :, repeat] == -1))
        kept = split[0] != -1
        self.assertFalse(np.any(kept[:, :repeat].any(axis=1) & kept[:, repeat + 1:].any(axis=1)))
        # Every other observation is kept once, the first part of each track under its own id.
        through = observed[:, :repeat].any(axis=1) & observed[:, repeat + 1:].any(axis=1)
        self.assertEqual(split.shape[1], features.shape[1] + through.sum())
        self.assertIn('%d tracks through them split' % through.sum(), proc.stdout)
        np.testing.assert_array_equal(split[:, :features.shape[1], :repeat],
                                      features[:, :, :repeat])
        moved = split[:, features.shape[1]:, repeat + 1:]
        np.testing.assert_array_equal(moved, features[:, through, repeat + 1:])
        self.assertTrue(np.all(split[:, :features.shape[1], repeat + 1:][:, through] == -1))
        # A file without repeats comes out unchanged.
        plain = self.variant('plain', '--twist', 'course', '--split-repeated')
        np.testing.assert_array_equal(plain['features'], np.load(self.prefix + '.npz')['features'])

    def test_frames_keep_a_section_of_every_per_frame_key(self):
        original = dict(np.load(self.prefix + '.npz'))
        v = self.variant('section', '--twist', 'course', '--frames', 30, 50)
        np.testing.assert_array_equal(v['time_stamps'], original['time_stamps'][:, 30:80])
        np.testing.assert_array_equal(v['features'], original['features'][:, :, 30:80])
        np.testing.assert_array_equal(v['linear_velocity'], original['linear_velocity'][:, 30:80])
        np.testing.assert_array_equal(v['K'], original['K'])
        # The accurate twist of a section is the ground truth's over the section's frames.
        exact = self.variant('section_exact', '--twist', 'accurate', '--twist-noise', 0, 0,
                             '--gyro-offset', 0, '--frames', 30, 50)
        t_gt, T_gt = trajectory.read_tum(self.gt)
        T = T_gt[30].copy()
        t = exact['time_stamps'].ravel()
        for k in range(1, t.size):
            T = T @ se3.twist_exp(exact['linear_velocity'][:, k],
                                  exact['rotational_velocity'][:, k], t[k] - t[k - 1])
        self.assertLess(np.linalg.norm(T[:3, 3] - T_gt[79, :3, 3]), 1e-6)
        for bad in (('110', '20'), ('0', '1'), ('-1', '10')):
            proc = ekf_test_paths.run_script('make_variant.py', self.prefix + '.npz',
                                             '--groundtruth', self.gt, '--twist', 'course',
                                             '--frames', *bad,
                                             '--out', os.path.join(self.tmp, 'bad.npz'))
            self.assertEqual(proc.returncode, 2, bad)
            self.assertIn('frames', proc.stderr)

    def test_bad_input_is_one_line(self):
        proc = ekf_test_paths.run_script('make_variant.py', self.prefix + '.npz', '--groundtruth',
                                         self.gt, '--twist', 'course', '--keep-fraction', 0,
                                         '--out', os.path.join(self.tmp, 'x.npz'))
        self.assertEqual(proc.returncode, 2)
        self.assertEqual(len(proc.stderr.strip().splitlines()), 1, proc.stderr)


if __name__ == '__main__':
    unittest.main()
