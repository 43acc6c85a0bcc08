#!/usr/bin/python3
"""rostest of the tracker's stereo rig check (see stereo_rig_check.test): a short rendered drive
played into a tracker that gets its images as recorded, one that gets them swapped, one that
gets its right images moved by a pixel and one that gets them turned by 0.2 degrees; only the
second's diagnostics name the swap, only the third's the disparity offset (and the third takes
it out of its published features), only the fourth's the turn."""
import os
import shutil
import sys
import tempfile
import threading
import unittest

import numpy as np
import rosbag
import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticStatus
from ekf_vislam.msg import StereoFeatureArray

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from vislam_rostest import (STEREO_INPUTS, NewestStatuses, log,  # noqa: E402
                            rendered_drive_bag, run_script, stereo_inputs_required)

from ekf_vislam_tools.bag_playback import play_bag, wait_until  # noqa: E402

PKG = 'ekf_vislam'
FRAMES = 20
PLAY_RATE = 1.0
RIGHT_SHIFT_PX = 1.0
OFFSET_NS = '/offset'
RIGHT_ROLL_DEG = 0.2
TURNED_NS = '/turned'


def variant_bag(tmp, name, namespace, options):
    """The rendered drive in TMP/drive copied by image_variant.py with OPTIONS, as a bag whose
    stereo topics lie under NAMESPACE: TMP/NAME.bag."""
    folder = os.path.join(tmp, name)
    bag, renamed = os.path.join(tmp, name + '_images.bag'), os.path.join(tmp, name + '.bag')
    run_script('image_variant.py', os.path.join(tmp, 'drive'), folder, *options)
    run_script('play_stereo_images.py', folder, '--bag', bag)
    with rosbag.Bag(bag) as source, rosbag.Bag(renamed, 'w') as out:
        for topic, msg, stamp in source.read_messages(topics=list(STEREO_INPUTS)):
            out.write(namespace + topic, msg, stamp)
    return renamed


class StereoRigCheckTest(NewestStatuses, unittest.TestCase):

    @classmethod
    def setUpClass(cls):
        rospy.init_node('stereo_rig_check_rostest', anonymous=True)
        cls.tmp = tempfile.mkdtemp(prefix='ekf_vislam_rig_check_')
        bag = rendered_drive_bag(cls.tmp, FRAMES)
        offset_bag = variant_bag(cls.tmp, 'offset', OFFSET_NS,
                                 ['--right-shift', str(RIGHT_SHIFT_PX)])
        turned_bag = variant_bag(cls.tmp, 'turned', TURNED_NS,
                                 ['--right-roll', str(RIGHT_ROLL_DEG)])
        cls.lock = threading.Lock()
        cls.listen_to_diagnostics()
        # The features of the tracker as recorded and of the one whose right images are moved:
        # their left images are the same, so are their tracks' left positions.
        cls.features = {'/stereo/features': {}, OFFSET_NS + '/stereo/features': {}}
        listening = [rospy.Subscriber(topic, StereoFeatureArray, cls.keep_features,
                                      callback_args=topic, queue_size=100)
                     for topic in cls.features]
        required = stereo_inputs_required(('/tracker_as_recorded', '/swapped/tracker_swapped'))
        for namespace, node in ((OFFSET_NS, '/tracker_offset'), (TURNED_NS, '/tracker_turned')):
            required.update({namespace + topic: (namespace + node,) for topic in STEREO_INPUTS})
        # The bags in one player: one clock, their messages in the order of their times.
        play_bag(bag, '/stereo_rig_check_player', PLAY_RATE, required,
                 extra_args=[offset_bag, turned_bag], listening=listening)

        def tracked_everything():
            return all(int(cls.values(name).get('pairs_tracked', 0)) >= FRAMES - 1
                       for name in ('tracker_as_recorded', 'tracker_swapped', 'tracker_offset',
                                    'tracker_turned'))
        wait_until(tracked_everything, 30.0)
        wait_until(lambda: 'swapped' in cls.message('tracker_swapped'), 5.0)
        wait_until(lambda: 'disparity' in cls.message('tracker_offset'), 5.0)
        wait_until(lambda: 'turned' in cls.message('tracker_turned'), 5.0)

    @classmethod
    def keep_features(cls, msg, topic):
        with cls.lock:
            cls.features[topic][msg.header.stamp.to_nsec()] = np.array(
                [(f.u_left, f.v_left, f.u_left - f.u_right) for f in msg.features]).reshape(-1, 3)

    @classmethod
    def status(cls, name_part):
        return cls.latest_status(name_part)[0]

    @classmethod
    def values(cls, name_part):
        return cls.latest_status(name_part)[1]

    @classmethod
    def message(cls, name_part):
        status = cls.status(name_part)
        return status.message if status else ''

    @classmethod
    def log_beside_recorded(cls, name, prefixes):
        """Logs the status message of the node `name` and its figures whose keys start with one
        of `prefixes`, then the same of the node that gets the images as recorded."""
        def figures(node):
            return {k: v for k, v in cls.values(node).items() if k.startswith(prefixes)}
        log('%s: "%s" %s; as recorded: "%s" %s' % (
            name, cls.message(name), figures(name), cls.message('tracker_as_recorded'),
            figures('tracker_as_recorded')))

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.tmp, ignore_errors=True)

    def test_swapped_images_are_named(self):
        swapped, recorded = self.values('tracker_swapped'), self.values('tracker_as_recorded')
        self.log_beside_recorded('tracker_swapped', ('stereo_row', 'stereo_neg'))
        self.assertIn('swapped', self.message('tracker_swapped'))
        self.assertEqual(self.status('tracker_swapped').level, DiagnosticStatus.WARN)
        self.assertGreater(float(swapped['stereo_negative_disparity_fraction']), 0.9)
        self.assertEqual(self.status('tracker_as_recorded').level, DiagnosticStatus.OK)
        self.assertLess(float(recorded['stereo_negative_disparity_fraction']), 0.05)
        self.assertLess(float(recorded['stereo_row_failed_fraction']), 0.1)
        self.assertLess(abs(float(recorded['stereo_row_offset_px'])), 0.2)

    def test_a_disparity_offset_is_named(self):
        offset, recorded = self.values('tracker_offset'), self.values('tracker_as_recorded')
        self.log_beside_recorded('tracker_offset', ('disparity_offset',))
        self.assertEqual(self.status('tracker_offset').level, DiagnosticStatus.WARN)
        self.assertIn('px below the true one', self.message('tracker_offset'))
        self.assertIn('are corrected by it', self.message('tracker_offset'))
        self.assertGreaterEqual(int(offset['disparity_offset_pairs']), 10)
        self.assertAlmostEqual(float(offset['disparity_offset_corrected_px']), -RIGHT_SHIFT_PX,
                               delta=0.15)
        self.assertEqual(float(recorded['disparity_offset_corrected_px']), 0.0)
        self.assertAlmostEqual(float(offset['disparity_offset_px']), -RIGHT_SHIFT_PX, delta=0.15)
        self.assertGreaterEqual(int(recorded['disparity_offset_pairs']), 10)
        self.assertLess(abs(float(recorded['disparity_offset_px'])), 0.15)

    def test_the_offset_is_taken_out_of_the_published_features(self):
        """The last pair's features of the moved right images carry the disparities of those as
        recorded (stereo/correct_disparity_offset): the same left positions, disparities within
        0.15 px (1 px apart without the correction)."""
        with self.lock:
            recorded = self.features['/stereo/features']
            moved = self.features[OFFSET_NS + '/stereo/features']
            stamp = max(set(recorded) & set(moved))
            recorded, moved = recorded[stamp], moved[stamp]
        # Each recorded feature's nearest moved one, where it lies within 0.1 px.
        distance = np.linalg.norm(recorded[:, None, :2] - moved[None, :, :2], axis=2)
        nearest = distance.argmin(axis=1)
        same = distance[np.arange(len(recorded)), nearest] < 0.1
        difference = moved[nearest[same], 2] - recorded[same, 2]
        log('last pair: %d of %d features at the same left position; disparity moved - recorded: '
            'median %.3f px' % (same.sum(), len(recorded), np.median(difference)))
        self.assertGreater(same.sum(), 0.5 * len(recorded))
        self.assertLess(abs(np.median(difference)), 0.15)

    def test_a_turned_right_image_is_named(self):
        turned, recorded = self.values('tracker_turned'), self.values('tracker_as_recorded')
        self.log_beside_recorded('tracker_turned', ('stereo_roll',))
        self.assertEqual(self.status('tracker_turned').level, DiagnosticStatus.WARN)
        self.assertIn('turned 0.2', self.message('tracker_turned'))
        self.assertIn('degrees clockwise', self.message('tracker_turned'))
        self.assertAlmostEqual(float(turned['stereo_roll_deg']), RIGHT_ROLL_DEG, delta=0.02)
        self.assertGreater(float(turned['stereo_roll_edge_px']), 0.75)
        self.assertLess(abs(float(recorded['stereo_roll_deg'])), 0.01)
        self.assertLess(abs(float(self.values('tracker_offset')['stereo_roll_deg'])), 0.01)


if __name__ == '__main__':
    rostest.rosrun(PKG, 'stereo_rig_check', StereoRigCheckTest)
