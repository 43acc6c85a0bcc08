// The standalone node and the nodelet of a ROS wrapper class (VislamRos, StereoTrackerRos,
// TwistCombinerRos): each is constructed from (node handle, private node handle, name), and a
// wrapper with a shutdown() method has it called when the node or nodelet ends (it processes what
// is buffered and saves). Every node main and nodelet of the package is a line over these.
#pragma once

#include <nodelet/nodelet.h>
#include <ros/ros.h>

#include <exception>
#include <memory>
#include <type_traits>
#include <utility>

namespace ekf_vislam {

namespace thin_wrappers_detail {
template <typename Wrapper, typename = void>
struct HasShutdown : std::false_type {};
template <typename Wrapper>
struct HasShutdown<Wrapper, std::void_t<decltype(std::declval<Wrapper&>().shutdown())>>
    : std::true_type {};

template <typename Wrapper>
void shutdown(Wrapper& wrapper) {
  if constexpr (HasShutdown<Wrapper>::value) wrapper.shutdown();
}
}  // namespace thin_wrappers_detail

/// main() of a standalone node over Wrapper: exit status 1 (ROS_FATAL) when it cannot start.
template <typename Wrapper>
int runNode(int argc, char** argv, const char* default_name) {
  ros::init(argc, argv, default_name);
  ros::NodeHandle nh;
  ros::NodeHandle pnh("~");
  try {
    Wrapper wrapper(nh, pnh, ros::this_node::getName());
    ros::spin();
    thin_wrappers_detail::shutdown(wrapper);
  } catch (const std::exception& e) {
    ROS_FATAL("%s: %s", ros::this_node::getName().c_str(), e.what());
    return 1;
  }
  return 0;
}

/// A nodelet over Wrapper (derive a named class from it for PLUGINLIB_EXPORT_CLASS).
template <typename Wrapper>
class WrapperNodelet : public nodelet::Nodelet {
 public:
  ~WrapperNodelet() override {
    if (wrapper_) thin_wrappers_detail::shutdown(*wrapper_);
  }

 private:
  void onInit() override {
    wrapper_ = std::make_unique<Wrapper>(getNodeHandle(), getPrivateNodeHandle(), getName());
  }
  std::unique_ptr<Wrapper> wrapper_;
};

}  // namespace ekf_vislam
