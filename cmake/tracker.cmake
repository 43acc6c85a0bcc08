# Stereo front end (included from CMakeLists.txt after the estimator targets):
#  - ekf_vislam_tracker: the ROS-free tracker core (OpenCV + Eigen), src/tracker;
#  - track_stereo_images: the offline tool over a KITTI-layout image folder;
#  - ekf_vislam_tracker_nodelet (ekf_vislam/StereoTrackerNodelet) and stereo_tracker_node;
#  - ekf_vislam_tracker_test and ekf_vislam_tracker_ros_test (gtest), registered with ctest.
find_package(OpenCV REQUIRED COMPONENTS core imgproc imgcodecs features2d video calib3d)
find_package(cv_bridge REQUIRED)
find_package(image_transport REQUIRED)
find_package(message_filters REQUIRED)

add_library(ekf_vislam_tracker
  src/tracker/tracker_options.cc
  src/tracker/feature_detector.cc
  src/tracker/image_mask.cc
  src/tracker/klt_back_check.cc
  src/tracker/pyramidal_klt.cc
  src/tracker/exposure_compensation.cc
  src/tracker/stereo_matcher.cc
  src/tracker/stereo_rig_check.cc
  src/tracker/patch_refiner.cc
  src/tracker/rectified_stereo.cc
  src/tracker/pnp_ransac.cc
  src/tracker/motion_check.cc
  src/tracker/disparity_offset_fit.cc
  src/tracker/stereo_roll_fit.cc
  src/tracker/frame_rate_limit.cc
  src/tracker/deep_image_scale.cc
  src/tracker/image_rectifier.cc
  src/tracker/stereo_tracker.cc
  src/tracker/debug_drawing.cc
  src/tracker/kitti_sequence.cc
  src/tracker/npz_writer.cc
  src/tracker/feature_columns.cc
  src/tracker/pose_twist.cc
  src/tracker/twist_motion_prior.cc
  src/tracker/track_quality.cc)
target_include_directories(ekf_vislam_tracker SYSTEM PUBLIC ${OpenCV_INCLUDE_DIRS})
target_link_libraries(ekf_vislam_tracker ekf_vislam_core ${OpenCV_LIBS})

add_executable(track_stereo_images src/tracker/track_stereo_images.cc)
target_link_libraries(track_stereo_images ekf_vislam_tracker)

install(TARGETS ekf_vislam_tracker track_stereo_images
  ARCHIVE DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION}
  LIBRARY DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION}
  RUNTIME DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})

if(CATKIN_ENABLE_TESTING)
  catkin_add_gtest(ekf_vislam_tracker_test
    src/core/gtest_main.cc
    src/tracker/tracker_options_test.cc
    src/tracker/feature_detector_test.cc
    src/tracker/image_mask_test.cc
    src/tracker/debug_drawing_test.cc
    src/tracker/npz_writer_test.cc
    src/tracker/feature_columns_test.cc
    src/tracker/pose_twist_test.cc
    src/tracker/twist_motion_prior_test.cc
    src/tracker/klt_back_check_test.cc
    src/tracker/pyramidal_klt_test.cc
    src/tracker/pnp_ransac_test.cc
    src/tracker/disparity_offset_fit_test.cc
    src/tracker/stereo_roll_fit_test.cc
    src/tracker/frame_rate_limit_test.cc
    src/tracker/deep_image_scale_test.cc
    src/tracker/kitti_sequence_test.cc
    src/tracker/exposure_compensation_test.cc
    src/tracker/image_rectifier_test.cc
    src/tracker/stereo_tracker_test.cc
    src/tracker/stereo_rig_check_test.cc
    src/tracker/patch_refiner_test.cc
    src/tracker/rectified_stereo_test.cc
    src/tracker/track_quality_test.cc
    src/tracker/motion_check_test.cc
    src/tracker/stereo_matcher_test.cc
    src/tracker/kitti_clips_test.cc)
  target_include_directories(ekf_vislam_tracker_test PRIVATE ${PROJECT_SOURCE_DIR}/src/tracker)
  target_link_libraries(ekf_vislam_tracker_test ekf_vislam_tracker)
  target_compile_definitions(ekf_vislam_tracker_test PRIVATE
    EKF_VISLAM_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
endif()

# ROS layer of the tracker (thin: messages in and out).
add_library(ekf_vislam_tracker_ros src/ros/stereo_tracker_ros.cc src/ros/gray_image.cc
  src/ros/stereo_pair_rectifier.cc
  src/ros/feature_message.cc)
target_include_directories(ekf_vislam_tracker_ros SYSTEM PUBLIC
  ${cv_bridge_INCLUDE_DIRS} ${image_transport_INCLUDE_DIRS} ${message_filters_INCLUDE_DIRS})
target_link_libraries(ekf_vislam_tracker_ros ekf_vislam_tracker ekf_vislam_ros
  ${cv_bridge_LIBRARIES} ${image_transport_LIBRARIES} ${message_filters_LIBRARIES}
  ${catkin_LIBRARIES})
add_dependencies(ekf_vislam_tracker_ros ${PROJECT_NAME}_generate_messages_cpp)

add_library(ekf_vislam_tracker_nodelet src/ros/stereo_tracker_nodelet.cc)
target_link_libraries(ekf_vislam_tracker_nodelet ekf_vislam_tracker_ros)

add_executable(stereo_tracker_node src/ros/stereo_tracker_node.cc)
target_link_libraries(stereo_tracker_node ekf_vislam_tracker_ros)

# The tracker over a recorded bag (no roscore): a bag of its features for vislam_offline.
add_executable(track_stereo_bag src/ros/track_stereo_bag.cc src/ros/bag_stereo_tracker.cc)
target_link_libraries(track_stereo_bag ekf_vislam_tracker_ros)

if(CATKIN_ENABLE_TESTING)
  catkin_add_gtest(ekf_vislam_tracker_ros_test src/core/gtest_main.cc src/ros/gray_image_test.cc
    src/ros/stereo_pair_rectifier_test.cc)
  target_include_directories(ekf_vislam_tracker_ros_test PRIVATE ${PROJECT_SOURCE_DIR}/src/tracker)
  target_link_libraries(ekf_vislam_tracker_ros_test ekf_vislam_tracker_ros)
endif()

install(TARGETS ekf_vislam_tracker_ros ekf_vislam_tracker_nodelet stereo_tracker_node
  track_stereo_bag
  ARCHIVE DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION}
  LIBRARY DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION}
  RUNTIME DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})
install(PROGRAMS scripts/play_stereo_images.py scripts/render_stereo_drive.py
  DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})
if(TARGET tests)
  add_dependencies(tests ekf_vislam_tracker_nodelet stereo_tracker_node track_stereo_images
    track_stereo_bag)
endif()
