// Standalone node hosting the same StereoSlamNodelet class, for users who do not run a
// nodelet manager. Remappings and private parameters apply exactly as for the nodelet.
//
// A refused configuration or map file makes the nodelet's onInit throw, so the load fails and
// the node exits with status 1 right away (the nodelet logged the one-line FATAL reason):
// roslaunch reports the death, and required="true" / respawn can act on it.
#include <exception>

#include <nodelet/loader.h>
#include <ros/ros.h>

int main(int argc, char** argv) {
  ros::init(argc, argv, "pl_slam");
  nodelet::Loader loader;
  const nodelet::M_string remappings(ros::names::getRemappings());
  const nodelet::V_string my_argv(argv + 1, argv + argc);
  bool loaded = false;
  try {
    loaded =
        loader.load(ros::this_node::getName(), "pl_slam/StereoSlamNodelet", remappings, my_argv);
  } catch (const std::exception&) {
    // A loader that lets onInit's exception through: the same refusal.
  }
  if (!loaded) {
    // The nodelet logged why (refused parameters or map file); a missing plugin is reported
    // by the loader itself. Nothing else to say: one line, then exit non-zero.
    loader.clear();
    ros::shutdown();
    return 1;
  }
  ros::spin();
  // Unload before the loader is destroyed so the worker thread stops while ROS is still up.
  loader.unload(ros::this_node::getName());
  return 0;
}
