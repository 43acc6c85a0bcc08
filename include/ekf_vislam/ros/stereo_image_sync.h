// The synchronizer that pairs the left and right images, built one way for the live node
// (StereoTrackerRos, fed by its subscribers) and for track_stereo_bag (fed in bag order), so that
// both pair the same images.
#pragma once

#include "ekf_vislam/tracker/tracker_options.h"

#include <message_filters/sync_policies/approximate_time.h>
#include <message_filters/synchronizer.h>
#include <ros/duration.h>

#include <memory>

namespace ekf_vislam {

template <class Image>
using StereoImageSyncPolicy = message_filters::sync_policies::ApproximateTime<Image, Image>;
/// Input 0 the left image, 1 the right one; Image is sensor_msgs::Image or CompressedImage.
template <class Image>
using StereoImageSync = message_filters::Synchronizer<StereoImageSyncPolicy<Image>>;

/// message_filters' ApproximateTime over ros/queue_size images per camera. It emits a pair once
/// it can prove that no later image pairs better. Told that one camera's images lie at least
/// twice ros/max_stamp_difference apart, it proves that at once for every pair whose stamps
/// differ by no more than ros/max_stamp_difference (the pairs the node takes); without it, a pair
/// whose stamps differ at all waits for the next image, a whole frame period. (A camera faster
/// than that bound, 250 Hz at the default, would make the tolerance itself ambiguous: two images
/// of one camera within it of the other's.) Pairs further apart are emitted too, later: the
/// caller counts and skips them (unsynchronized).
template <class Image>
std::unique_ptr<StereoImageSync<Image>> makeStereoImageSync(
    const StereoTrackerRosOptions& options) {
  auto sync = std::make_unique<StereoImageSync<Image>>(
      StereoImageSyncPolicy<Image>(static_cast<uint32_t>(options.queue_size)));
  sync->setInterMessageLowerBound(ros::Duration(2.0 * options.max_stamp_difference));
  return sync;
}

}  // namespace ekf_vislam
