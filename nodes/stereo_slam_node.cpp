// Standalone node hosting the same StereoSlamNodelet class, for users who do not run a
// nodelet manager. Remappings and private parameters apply exactly as for the nodelet.
#include <nodelet/loader.h>
#include <ros/ros.h>

int main(int argc, char** argv) {
  ros::init(argc, argv, "pl_slam");
  nodelet::Loader loader;
  const nodelet::M_string remappings(ros::names::getRemappings());
  const nodelet::V_string my_argv(argv + 1, argv + argc);
  if (!loader.load(ros::this_node::getName(), "pl_slam/StereoSlamNodelet", remappings, my_argv)) {
    ROS_FATAL("pl_slam: could not load the pl_slam/StereoSlamNodelet plugin");
    return 1;
  }
  ros::spin();
  // Unload before the loader is destroyed so the worker thread stops while ROS is still up.
  loader.unload(ros::this_node::getName());
  return 0;
}
