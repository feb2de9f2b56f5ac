// The stereo calibration self-check on rendered frames with an exact calibration: it finds
// no offset where there is none, finds a known one where the right images are shifted, and
// refuses pairs that cannot tell (no translation, bad images) with a reason.
#include <memory>

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "pl_slam/camera/stereo_check.h"
#include "pl_slam/sim/synthetic_sequence.h"

namespace pl_slam {
namespace {

/// The right image moved `px` pixels to the right: the right principal point then lies px
/// right of the left one's, doffs = px.
cv::Mat ShiftRight(const cv::Mat& image, double px) {
  const cv::Mat shift = (cv::Mat_<double>(2, 3) << 1, 0, px, 0, 1, 0);
  cv::Mat out;
  cv::warpAffine(image, out, shift, image.size(), cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  return out;
}

StereoCheckSummary CheckRoom(double shift_px) {
  sim::SequenceOptions so;
  so.scene = sim::SceneKind::kRoom;
  const sim::SyntheticSequence seq(so);
  std::vector<StereoPairCheck> checks;
  for (int a = 0; a < 200; a += 8) {
    const StereoFrame fa = seq.Render(a), fb = seq.Render(a + 6);
    checks.push_back(CheckStereoPair(seq.camera(), fa.left, ShiftRight(fa.right, shift_px), fb.left,
                                     ShiftRight(fb.right, shift_px)));
    if (!checks.back().usable) std::cout << "pair " << a << ": " << checks.back().reason << "\n";
  }
  return SummariseStereoChecks(checks);
}

TEST(StereoCheckTest, FindsNoOffsetInAnExactCalibrationAndAKnownOneInAShiftedPair) {
  const StereoCheckSummary exact = CheckRoom(0.0), shifted = CheckRoom(1.0);
  std::cout << "exact: doffs " << exact.doffs << " +- " << exact.doffs_error << " px from "
            << exact.pairs << " pairs; right images shifted by 1 px: " << shifted.doffs << " +- "
            << shifted.doffs_error << " px from " << shifted.pairs << " pairs\n";
  ASSERT_GE(exact.pairs, 8);
  ASSERT_GE(shifted.pairs, 8);
  EXPECT_NEAR(exact.doffs, 0.0, 0.15);
  EXPECT_NEAR(shifted.doffs, 1.0, 0.15);
  EXPECT_FALSE(StereoOffsetDiffers(exact, 0.0));
  EXPECT_TRUE(StereoOffsetDiffers(shifted, 0.0));
  EXPECT_FALSE(StereoOffsetDiffers(shifted, 1.0));
}

/// A recording whose right images are shifted `px` pixels to the right.
class ShiftedRightSource : public StereoSource {
 public:
  ShiftedRightSource(std::unique_ptr<StereoSource> inner, double px)
      : inner_(std::move(inner)), px_(px) {}
  const StereoCamera& camera() const override { return inner_->camera(); }
  std::size_t size() const override { return inner_->size(); }
  bool Next(StereoFrame* frame) override {
    if (!inner_->Next(frame)) return false;
    frame->right = ShiftRight(frame->right, px_);
    return true;
  }
  const Trajectory& ground_truth() const override { return inner_->ground_truth(); }
  std::string Describe() const override { return inner_->Describe() + ", right shifted"; }

 private:
  std::unique_ptr<StereoSource> inner_;
  double px_;
};

// The whole-recording pass (pl_slam_check_stereo, pl_slam_offline --doffs auto): 80 frames of
// the room with the right images shifted by 1 px give 40 anchors x 4 gaps, and the offset.
TEST(StereoCheckTest, MeasuresARecordingsOffsetOverSpreadAnchors) {
  sim::SequenceOptions so;
  so.scene = sim::SceneKind::kRoom;
  ShiftedRightSource source(std::make_unique<sim::SyntheticSequence>(so), 1.0);
  int seen = 0, last_frame = -1;
  const StereoOffsetMeasurement m =
      MeasureStereoOffset(&source, 80, [&](int anchor, int frame, const StereoPairCheck&) {
        ++seen;
        EXPECT_EQ(anchor % 2, 0) << "anchors every 2 frames for 80 frames";
        EXPECT_GE(frame, last_frame);
        last_frame = frame;
      });
  std::cout << m.summary.pairs << " of " << m.tried << " pairs usable over " << m.frames
            << " frames: doffs " << m.summary.doffs << " +- " << m.summary.doffs_error << " px\n";
  EXPECT_EQ(m.frames, 80);
  EXPECT_EQ(m.tried, seen);
  EXPECT_GT(m.tried, 120);
  ASSERT_TRUE(m.conclusive());
  EXPECT_NEAR(m.summary.doffs, 1.0, 0.15);
  EXPECT_TRUE(StereoOffsetDiffers(m.summary, 0.0));
}

TEST(StereoCheckTest, RefusesPairsThatCannotTell) {
  sim::SequenceOptions so;
  so.scene = sim::SceneKind::kRoom;
  const sim::SyntheticSequence seq(so);
  const StereoFrame f = seq.Render(0);
  // The same frame twice: no translation, so depth says nothing about the motion.
  const StereoPairCheck still = CheckStereoPair(seq.camera(), f.left, f.right, f.left, f.right);
  EXPECT_FALSE(still.usable);
  EXPECT_NE(still.reason.find("translation"), std::string::npos) << still.reason;
  const StereoPairCheck empty = CheckStereoPair(seq.camera(), f.left, cv::Mat(), f.left, f.right);
  EXPECT_FALSE(empty.usable);
  EXPECT_NE(empty.reason.find("images"), std::string::npos) << empty.reason;
  StereoCheckOptions bad;
  bad.corners = 0;
  EXPECT_FALSE(CheckStereoPair(seq.camera(), f.left, f.right, f.left, f.right, bad).usable);
  EXPECT_EQ(SummariseStereoChecks({still, empty}).pairs, 0);
}

}  // namespace
}  // namespace pl_slam
