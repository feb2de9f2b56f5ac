// static_tf_publisher: publishes one fixed transform on /tf_static (latched), like tf2_ros'
// static_transform_publisher, which Debian does not package. Launch files use it for the
// camera mount (base_link -> camera optical frame).
//
//   static_tf_publisher x y z yaw pitch roll parent child       (angles in radians, ZYX)
//   static_tf_publisher x y z qx qy qz qw parent child
//   static_tf_publisher _parent:=P _child:=C [_x:= _y:= _z:= _yaw:= _pitch:= _roll:=]
#include <cmath>
#include <cstdlib>
#include <string>
#include <vector>

#include <geometry_msgs/TransformStamped.h>
#include <ros/ros.h>
#include <tf2/LinearMath/Quaternion.h>
#include <tf2_ros/static_transform_broadcaster.h>

namespace {

constexpr char kUsage[] =
    "usage: static_tf_publisher x y z yaw pitch roll parent_frame child_frame\n"
    "       static_tf_publisher x y z qx qy qz qw parent_frame child_frame\n"
    "       static_tf_publisher _parent:=P _child:=C [_x _y _z _yaw _pitch _roll]\n"
    "(metres, radians; yaw about z, then pitch about y, then roll about x)";

bool ParseNumber(const std::string& text, double* value) {
  char* end = nullptr;
  *value = std::strtod(text.c_str(), &end);
  return end != text.c_str() && *end == '\0' && std::isfinite(*value);
}

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "static_tf_publisher", ros::init_options::AnonymousName);
  ros::NodeHandle nh;  // starts the node: ros::Time::now() needs it
  std::vector<std::string> args;
  ros::removeROSArgs(argc, argv, args);
  args.erase(args.begin());  // program name

  geometry_msgs::TransformStamped tf;
  double v[7] = {0, 0, 0, 0, 0, 0, 1};
  tf2::Quaternion q;
  if (args.size() == 8 || args.size() == 9) {
    const std::size_t n = args.size() - 2;
    for (std::size_t i = 0; i < n; ++i) {
      if (!ParseNumber(args[i], &v[i])) {
        ROS_FATAL("static_tf_publisher: argument %zu '%s' is not a number\n%s", i + 1,
                  args[i].c_str(), kUsage);
        return 1;
      }
    }
    tf.header.frame_id = args[n];
    tf.child_frame_id = args[n + 1];
    if (n == 6) {
      q.setRPY(v[5], v[4], v[3]);  // roll, pitch, yaw: the same rotation as ZYX yaw-pitch-roll
    } else {
      q = tf2::Quaternion(v[3], v[4], v[5], v[6]);
    }
  } else if (args.empty()) {
    ros::NodeHandle pnh("~");
    pnh.param<std::string>("parent", tf.header.frame_id, "");
    pnh.param<std::string>("child", tf.child_frame_id, "");
    const char* keys[6] = {"x", "y", "z", "yaw", "pitch", "roll"};
    for (int i = 0; i < 6; ++i) pnh.param(keys[i], v[i], 0.0);
    q.setRPY(v[5], v[4], v[3]);  // roll, pitch, yaw: the same rotation as ZYX yaw-pitch-roll
  } else {
    ROS_FATAL("static_tf_publisher: expected 8 or 9 arguments, got %zu\n%s", args.size(), kUsage);
    return 1;
  }
  if (tf.header.frame_id.empty() || tf.child_frame_id.empty() ||
      tf.header.frame_id == tf.child_frame_id) {
    ROS_FATAL("static_tf_publisher: parent '%s' and child '%s' must be distinct non-empty frames",
              tf.header.frame_id.c_str(), tf.child_frame_id.c_str());
    return 1;
  }
  if (!(q.length() > 1e-9)) {
    ROS_FATAL("static_tf_publisher: the rotation quaternion has zero length");
    return 1;
  }
  q.normalize();
  tf.header.stamp = ros::Time::now();
  tf.transform.translation.x = v[0];
  tf.transform.translation.y = v[1];
  tf.transform.translation.z = v[2];
  tf.transform.rotation.x = q.x();
  tf.transform.rotation.y = q.y();
  tf.transform.rotation.z = q.z();
  tf.transform.rotation.w = q.w();

  tf2_ros::StaticTransformBroadcaster broadcaster;
  broadcaster.sendTransform(tf);
  ROS_INFO("static_tf_publisher: %s -> %s: t = (%.4f, %.4f, %.4f), q = (%.4f, %.4f, %.4f, %.4f)",
           tf.header.frame_id.c_str(), tf.child_frame_id.c_str(), v[0], v[1], v[2], q.x(), q.y(),
           q.z(), q.w());
  ros::spin();
  return 0;
}
