#!/usr/bin/env bash
# Tracker and estimator live, faster than real time: a KITTI-layout folder (images, calib.txt,
# times.txt, poses.txt or --poses FILE for the twist) is written as a bag
# (play_stereo_images.py), played with `rosbag play --clock -r RATE` (paused until every node is
# connected) into launch/stereo_vislam.launch (one nodelet manager), and the features, twist and
# odometry are recorded. Prints the machine, the pairs received, tracked and dropped, the frames the
# estimator used, its update time and latency (diagnostics), the time the estimator finished
# after the last pair, whether vislam_offline on the recorded features reproduces the live
# trajectory bit for bit (live = offline), and whether track_stereo_bag on the images reproduces
# the live tracker's features bit for bit. Instead of a folder, a recorded bag (BAG.bag, images on
# the topics of stereo_vislam.launch, with twist, camera_info and /tf_static) is played as it is.
# Images as CompressedImage (a bag's image_rect/compressed topics, or a folder with --compressed
# png|jpeg, written by play_stereo_images.py) run the tracker with ros/image_transport compressed;
# raw images (a bag's image_raw topics, or a folder with --raw-camera) with ros/rectify true.
#   scripts/benchmark_live.sh FOLDER|BAG [--poses FILE] [--rate R] [--config estimator.yaml]
#                             [--tracker-config tracker.yaml] [--standalone] [--out DIR]
#                             [--compressed png|jpeg [--jpeg-quality Q]] [--raw-camera]
# --standalone: the two nodes (stereo_tracker_node, vislam_node) instead of one nodelet manager.
# Needs no roscore running on port 11399 (it starts its own there).
set -eo pipefail
export PATH=/usr/bin:/bin:${PATH}
REPO=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
FOLDER=""
RATE=3
CONFIG=""
TRACKER_CONFIG=""
STANDALONE=false
OUT=""
POSES=""
COMPRESS=()
while (($#)); do
  case "$1" in
    --rate) RATE=$2; shift 2 ;;
    --poses) POSES=$(readlink -f "$2"); shift 2 ;;
    --config) CONFIG=$(readlink -f "$2"); shift 2 ;;
    --tracker-config) TRACKER_CONFIG=$(readlink -f "$2"); shift 2 ;;
    --standalone) STANDALONE=true; shift ;;
    --out) OUT=$2; shift 2 ;;
    --compressed|--jpeg-quality) COMPRESS+=("$1" "$2"); shift 2 ;;
    --raw-camera) COMPRESS+=("$1"); shift ;;
    -h|--help) sed -n 2,19p "$0"; exit 0 ;;
    *) FOLDER=$1; shift ;;
  esac
done
if [[ ! -f "${FOLDER}" ]]; then
  POSES=${POSES:-${FOLDER}/poses.txt}
  [[ -f "${POSES}" ]] || { echo "benchmark_live: no ${POSES}: FOLDER/poses.txt or --poses FILE"; exit 2; }
fi
source "${REPO}/scripts/env.sh" >/dev/null
PYTHONPATH="${REPO}/src" /usr/bin/python3 -c \
  'from ekf_vislam_tools.report import machine_description; print(machine_description())'
export ROS_MASTER_URI=http://localhost:11399
OUT=${OUT:-$(mktemp -d)}
mkdir -p "${OUT}"
OUT=$(readlink -f "${OUT}")
if [[ -f "${FOLDER}" ]]; then  # a recorded bag, with the topics of stereo_vislam.launch
  ln -sf "$(readlink -f "${FOLDER}")" "${OUT}/images.bag"
else
  /usr/bin/python3 "${REPO}/scripts/play_stereo_images.py" "${FOLDER}" --poses "${POSES}" \
    --bag "${OUT}/images.bag" "${COMPRESS[@]}" >/dev/null
fi
# The image topics: rectified, or raw (the tracker's ros/rectify), each as Image or CompressedImage,
# as the bag holds them.
read -r LEFT RIGHT TRANSPORT RECTIFY < <(/usr/bin/python3 -c "
import sys, rosbag
topics = rosbag.Bag(sys.argv[1]).get_type_and_topic_info()[1]
for base, rectify in (('image_rect', 'false'), ('image_raw', 'true')):
    for suffix, transport in (('', 'raw'), ('/compressed', 'compressed')):
        left = '/stereo/left/' + base + suffix
        if left in topics:
            sys.exit(print(left, left.replace('/left/', '/right/'), transport, rectify))
print('/stereo/left/image_rect /stereo/right/image_rect raw false')" "${OUT}/images.bag")
roscore -p 11399 >"${OUT}/roscore.log" 2>&1 &
CORE=$!
trap 'kill -INT ${CORE} 2>/dev/null || true' EXIT
until rostopic list >/dev/null 2>&1; do sleep 0.5; done
ARGS=(use_sim_time:=true output_dir:="${OUT}/live" standalone:="${STANDALONE}"
  image_transport:="${TRANSPORT}" rectify:="${RECTIFY}")
[[ -n "${CONFIG}" ]] && ARGS+=(config:="${CONFIG}")
[[ -n "${TRACKER_CONFIG}" ]] && ARGS+=(tracker_config:="${TRACKER_CONFIG}")
roslaunch ekf_vislam stereo_vislam.launch "${ARGS[@]}" >"${OUT}/launch.log" 2>&1 &
LAUNCH=$!
rosbag record -O "${OUT}/live.bag" /stereo/features /imu/twist /stereo/left/camera_info \
  /stereo/right/camera_info /tf_static /vislam/odometry_update /diagnostics \
  __name:=benchmark_live_record >"${OUT}/record.log" 2>&1 &
RECORD=$!
until rosservice list 2>/dev/null | grep -q /vislam/save; do sleep 0.5; done
# Counts the estimator's per-frame outputs as they come; ends when every pair has one, or when
# none has come for 20 s, and writes the count and the wall time of the last one.
PAIRS=$(/usr/bin/python3 -c "import rosbag, sys; print(rosbag.Bag(sys.argv[1]).get_message_count(sys.argv[2]))" "${OUT}/images.bag" "${LEFT}")
/usr/bin/python3 - "${PAIRS}" "${OUT}/outputs.txt" <<'PY' &
import sys, time
import rospy
from nav_msgs.msg import Odometry
pairs, path = int(sys.argv[1]), sys.argv[2]
seen = {'count': 0, 'last': time.time()}
def on_odometry(_):
    seen['count'] += 1
    seen['last'] = time.time()
rospy.init_node('benchmark_live_count')
rospy.Subscriber('/vislam/odometry_update', Odometry, on_odometry, queue_size=100000)
while seen['count'] < pairs and time.time() - seen['last'] < 20.0:
    time.sleep(0.05)
open(path, 'w').write('%d %.6f\n' % (seen['count'], seen['last']))
PY
COUNTER=$!
# The player starts paused and resumes once the nodelets, the recorder and the counter are
# connected (bag_playback), so no pair and no output is lost to a slow start.
/usr/bin/python3 - "${OUT}/images.bag" "${RATE}" "${STANDALONE}" "${LEFT}" "${RIGHT}" \
  >"${OUT}/play.log" 2>&1 <<'PY'
import sys
import rospy
from ekf_vislam_tools import bag_playback
bag, rate, standalone = sys.argv[1], float(sys.argv[2]), sys.argv[3] == 'true'
images = sys.argv[4:6]
recorder, counter = '/benchmark_live_record', '/benchmark_live_count'
# The nodes that publish and subscribe: one manager, or the two standalone nodes.
tracker, estimator = ('/stereo_tracker', '/vislam') if standalone else ('/stereo_vislam_manager',) * 2
rospy.init_node('benchmark_live_play', anonymous=True)
outputs = ((tracker, {'/stereo/features': (recorder,)}),
           (estimator, {'/vislam/odometry_update': (recorder, counter)}))
if not bag_playback.wait_until(lambda: all(bag_playback.publisher_connected(node, topics)
                                           for node, topics in outputs), 30.0):
    sys.exit('benchmark_live: the recorder and the counter did not connect to the nodes')
inputs = {topic: tuple({tracker, estimator}) + (recorder,)
          for topic in ('/imu/twist', '/stereo/left/camera_info', '/stereo/right/camera_info')}
inputs.update({topic: (tracker,) for topic in images})
bag_playback.play_bag(bag, '/benchmark_live_player', rate, inputs, timeout=3600)
PY
PLAY_END=$(date +%s.%N)
wait "${COUNTER}"
rosservice call /vislam/save >/dev/null
sleep 1
kill -INT "${RECORD}"; wait "${RECORD}" || true
kill -INT "${LAUNCH}"; wait "${LAUNCH}" || true
TOOL=$(catkin_find --first-only --libexec ekf_vislam)/vislam_offline
OFFLINE_ARGS=(--bag "${OUT}/live.bag" --mode slam --out "${OUT}/offline")
[[ -n "${CONFIG}" ]] && OFFLINE_ARGS+=(--config "${CONFIG}")
"${TOOL}" "${OFFLINE_ARGS[@]}" >"${OUT}/offline.log" 2>&1
# The tracker offline on the same images (track_stereo_bag), against the features it published.
BAG_ARGS=(--bag "${OUT}/images.bag" --out "${OUT}/tracked.bag" --left-topic "${LEFT}"
  --right-topic "${RIGHT}")
[[ -n "${TRACKER_CONFIG}" ]] && BAG_ARGS+=(--config "${TRACKER_CONFIG}")
[[ "${RECTIFY}" == true ]] && BAG_ARGS+=(--rectify)
"$(dirname "${TOOL}")/track_stereo_bag" "${BAG_ARGS[@]}" >"${OUT}/track_bag.log" 2>&1
/usr/bin/python3 - "${OUT}" "${RATE}" "${PLAY_END}" "${LEFT}" <<'PY'
import json, sys
import numpy as np
import rosbag
from ekf_vislam_tools.bag_reading import read_feature_rows
out, rate, play_end, left = sys.argv[1], sys.argv[2], float(sys.argv[3]), sys.argv[4]
outputs, done_end = open(out + '/outputs.txt').read().split()
last = {}
with rosbag.Bag(out + '/images.bag') as bag:
    pairs = bag.get_message_count(left)
with rosbag.Bag(out + '/live.bag') as bag:
    for _, msg, _ in bag.read_messages(topics=['/diagnostics']):
        for status in msg.status:
            last[status.name.split(':')[0]] = {kv.key: kv.value for kv in status.values}
tracker, estimator = last.get('stereo_tracker', {}), last.get('vislam', {})
live = np.loadtxt(out + '/live/trajectory.tum', ndmin=2)
offline = np.loadtxt(out + '/offline/trajectory.tum', ndmin=2)
same = live.shape == offline.shape and np.array_equal(live, offline)
diff = np.abs(live[:, 1:] - offline[:, 1:]).max() if live.shape == offline.shape else float('nan')
stats = json.load(open(out + '/live/stats.json'))
print('pairs played %d (%s) at %sx; tracker: received %s, tracked %s, skipped by input/max_rate_hz '
      '%s, dropped waiting %s, dropped from its backlog %s, out of order %s, missing %s; backlog '
      'peak %s MB' % (
          pairs, left, rate, tracker.get('pairs_received'), tracker.get('pairs_tracked'),
          tracker.get('pairs_skipped_rate'), tracker.get('pairs_dropped_waiting'),
          tracker.get('pairs_dropped_backlog'), tracker.get('pairs_out_of_order'),
          tracker.get('pairs_missing'),
          tracker.get('backlog_mb_peak')))
if left.endswith('/compressed'):
    print('tracker: the last pair took %s ms to decode' % tracker.get('decode_ms_last'))
if 'rectify_ms_last' in tracker:
    print('tracker: the last pair took %s ms to rectify' % tracker.get('rectify_ms_last'))
print('estimator: frames used %s of %s, update ms p99 %s, latency ms p50 %.2f, p99 %.2f, '
      'peak active landmarks %s; its last output %.2f s after the player ended (%s outputs)'
      % (stats['counters'].get('frame_used'), stats['frames'],
         estimator.get('update_ms_p99'), stats['latency_ms_p50'], stats['latency_ms_p99'],
         stats['peak_active_landmarks'], float(done_end) - play_end, outputs))
print('live = offline (vislam_offline on the recorded features): %s (%d poses, max |difference| %g)'
      % ('yes, bit for bit' if same else 'NO', len(live), diff))

live_features = read_feature_rows(out + '/live.bag')
bag_features = read_feature_rows(out + '/tracked.bag')
differ = sum(a != b for a, b in zip(live_features, bag_features))
print('live tracker = track_stereo_bag on the images: %s (%d and %d feature messages, %d differ)'
      % ('yes, bit for bit' if live_features == bag_features else 'NO', len(live_features),
         len(bag_features), differ))
PY
