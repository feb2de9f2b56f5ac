#include "pl_slam/ros/bag_io.h"

#include <cstdio>
#include <filesystem>
#include <set>

#include <geometry_msgs/PoseStamped.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/image_encodings.h>

#include "pl_slam/ros/camera_info_rectifier.h"
#include "pl_slam/ros/conversions.h"
#include "pl_slam/util/error.h"
#include "pl_slam/util/logging.h"

namespace pl_slam {
namespace ros_layer {

namespace {

/// Header stamp of an image message in nanoseconds.
int64_t StampOf(const sensor_msgs::Image& m) { return ToNanoseconds(m.header.stamp); }

}  // namespace

BagStereoSource::BagStereoSource(const std::string& path, const BagTopics& topics,
                                 const std::optional<StereoCamera>& calibration)
    : path_(path), topics_(topics) {
  if (!std::filesystem::exists(path)) throw InputError(path + ": bag file does not exist");
  try {
    bag_.open(path, rosbag::bagmode::Read);
  } catch (const rosbag::BagException& e) {
    throw InputError(path + ": cannot open as a rosbag (" + e.what() + ")");
  }
  try {
    // Which topics are there, and how many left images.
    std::set<std::string> present;
    {
      rosbag::View all(bag_);
      for (const rosbag::ConnectionInfo* c : all.getConnections()) present.insert(c->topic);
    }
    for (const std::string& t : {topics_.left_image, topics_.right_image}) {
      if (!present.count(t)) throw InputError(path + ": no messages on image topic " + t);
    }
    size_ = rosbag::View(bag_, rosbag::TopicQuery(topics_.left_image)).size();

    if (calibration) {
      camera_ = *calibration;
    } else {
      if (!present.count(topics_.left_info) || !present.count(topics_.right_info)) {
        throw InputError(path + ": no camera_info on " + topics_.left_info + " / " +
                         topics_.right_info + " and no calibration given");
      }
      sensor_msgs::CameraInfo::ConstPtr left, right;
      for (const rosbag::MessageInstance& m :
           rosbag::View(bag_, rosbag::TopicQuery(topics_.left_info))) {
        if ((left = m.instantiate<sensor_msgs::CameraInfo>())) break;
      }
      for (const rosbag::MessageInstance& m :
           rosbag::View(bag_, rosbag::TopicQuery(topics_.right_info))) {
        if ((right = m.instantiate<sensor_msgs::CameraInfo>())) break;
      }
      if (!left || !right)
        throw InputError(path + ": camera_info topics hold no sensor_msgs/CameraInfo");
      try {
        // Raw bags (distorted images, camera_info with D, R) are rectified while reading.
        rectifier_ = std::make_unique<StereoInfoRectifier>(*left, *right);
        camera_ = rectifier_->camera();
      } catch (const InputError& e) {
        throw InputError(path + ": " + e.what());
      }
    }
    if (present.count(topics_.ground_truth)) {
      for (const rosbag::MessageInstance& m :
           rosbag::View(bag_, rosbag::TopicQuery(topics_.ground_truth))) {
        auto p = m.instantiate<geometry_msgs::PoseStamped>();
        if (!p) continue;
        StampedPose sp;
        sp.t = p->header.stamp.toSec();
        sp.T_w_c = FromPoseMsg(p->pose);
        ground_truth_.push_back(sp);
      }
    }
    view_ = std::make_unique<rosbag::View>(bag_, rosbag::TopicQuery(std::vector<std::string>{
                                                     topics_.left_image, topics_.right_image}));
    it_ = view_->begin();
  } catch (const rosbag::BagException& e) {
    throw InputError(path + ": corrupt bag (" + e.what() + ")");
  }
}

BagStereoSource::~BagStereoSource() = default;

bool BagStereoSource::Next(StereoFrame* frame) {
  try {
    while (it_ != view_->end()) {
      // The instance refers into the iterator: read everything before advancing it.
      const rosbag::MessageInstance& m = *it_;
      auto img = m.instantiate<sensor_msgs::Image>();
      const std::string topic = m.getTopic();
      ++it_;
      if (!img) continue;
      const bool is_left = topic == topics_.left_image;
      const int64_t stamp = StampOf(*img);
      cv::Mat mono;
      try {
        mono = ImageToMono8(*img);
      } catch (const InputError& e) {
        throw InputError(path_ + ": " + topic + ": " + e.what());
      }
      auto& mine = is_left ? pending_left_ : pending_right_;
      auto& other = is_left ? pending_right_ : pending_left_;
      auto match = other.find(stamp);
      if (match == other.end()) {
        mine[stamp] = mono;
        // Partners arrive close together; anything far older will never pair.
        while (mine.size() > 8) {
          mine.erase(mine.begin());
          ++unpaired_;
        }
        continue;
      }
      frame->stamp_ns = stamp;
      frame->index = next_index_++;
      const cv::Mat left = is_left ? mono : match->second;
      const cv::Mat right = is_left ? match->second : mono;
      frame->left = left;
      frame->right = right;
      if (rectifier_) {
        try {
          rectifier_->Rectify(left, right, &frame->left, &frame->right);
        } catch (const InputError& e) {
          throw InputError(path_ + ": frame at " + std::to_string(stamp) + " ns: " + e.what());
        }
      }
      // Drop older unmatched partners: they can no longer find a pair.
      unpaired_ += static_cast<int>(std::distance(other.begin(), match));
      other.erase(other.begin(), std::next(match));
      return true;
    }
  } catch (const rosbag::BagException& e) {
    throw InputError(path_ + ": corrupt bag while reading (" + e.what() + ")");
  }
  return false;
}

StereoBagWriter::StereoBagWriter(const std::string& path, const StereoCamera& camera,
                                 const BagTopics& topics, const std::string& left_frame,
                                 const std::string& right_frame)
    : path_(path), tmp_path_(path + ".tmp"), topics_(topics) {
  StereoCameraToInfo(camera, left_frame, right_frame, &left_info_, &right_info_);
  Open();
}

StereoBagWriter::StereoBagWriter(const std::string& path, const sensor_msgs::CameraInfo& left_info,
                                 const sensor_msgs::CameraInfo& right_info, const BagTopics& topics)
    : path_(path),
      tmp_path_(path + ".tmp"),
      left_info_(left_info),
      right_info_(right_info),
      topics_(topics) {
  Open();
}

void StereoBagWriter::Open() {
  try {
    bag_.open(tmp_path_, rosbag::bagmode::Write);
    bag_.setCompression(rosbag::compression::Uncompressed);
  } catch (const rosbag::BagException& e) {
    throw InputError(path_ + ": cannot create bag (" + e.what() + ")");
  }
  open_ = true;
}

StereoBagWriter::~StereoBagWriter() {
  if (open_) {
    // Not closed explicitly (an exception unwound us): leave no half-written bag behind.
    try {
      bag_.close();
    } catch (...) {
    }
    std::remove(tmp_path_.c_str());
  }
}

void StereoBagWriter::Write(const StereoFrame& frame) {
  const ros::Time stamp = FromNanoseconds(frame.stamp_ns);
  if (stamp.isZero()) {
    throw InputError(path_ + ": frame " + std::to_string(frame.index) +
                     " has stamp 0, which ROS reads as 'unset' (offset the stamps)");
  }
  sensor_msgs::CameraInfo left_info = left_info_, right_info = right_info_;
  left_info.header.stamp = right_info.header.stamp = stamp;
  left_info.header.seq = right_info.header.seq = static_cast<uint32_t>(frame.index);
  for (int side = 0; side < 2; ++side) {
    const cv::Mat& img = side == 0 ? frame.left : frame.right;
    sensor_msgs::Image msg;
    msg.header.stamp = stamp;
    msg.header.frame_id = side == 0 ? left_info_.header.frame_id : right_info_.header.frame_id;
    msg.header.seq = static_cast<uint32_t>(frame.index);
    msg.height = static_cast<uint32_t>(img.rows);
    msg.width = static_cast<uint32_t>(img.cols);
    msg.encoding = sensor_msgs::image_encodings::MONO8;
    msg.step = static_cast<uint32_t>(img.cols);
    msg.data.resize(static_cast<size_t>(img.rows) * img.cols);
    for (int r = 0; r < img.rows; ++r) {
      std::copy(img.ptr<uint8_t>(r), img.ptr<uint8_t>(r) + img.cols,
                msg.data.begin() + r * img.cols);
    }
    bag_.write(side == 0 ? topics_.left_image : topics_.right_image, stamp, msg);
  }
  bag_.write(topics_.left_info, stamp, left_info);
  bag_.write(topics_.right_info, stamp, right_info);
}

void StereoBagWriter::WriteGroundTruth(const Trajectory& T_w_c, const std::string& world_frame) {
  for (const StampedPose& sp : T_w_c) {
    geometry_msgs::PoseStamped msg;
    msg.header.stamp = FromNanoseconds(static_cast<int64_t>(std::llround(sp.t * 1e9)));
    msg.header.frame_id = world_frame;
    msg.pose = ToPoseMsg(sp.T_w_c);
    bag_.write(topics_.ground_truth, msg.header.stamp, msg);
  }
}

void StereoBagWriter::Close() {
  if (!open_) return;
  bag_.close();
  open_ = false;
  std::error_code ec;
  std::filesystem::rename(tmp_path_, path_, ec);
  if (ec) throw InputError(path_ + ": cannot move finished bag into place (" + ec.message() + ")");
}

}  // namespace ros_layer
}  // namespace pl_slam
