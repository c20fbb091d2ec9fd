#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "test_support.hpp"

namespace fl::logic {
namespace {

constexpr float kPi = std::numbers::pi_v<float>;

// All eight states of thesis figure 5.14 (hand x side up x which end leads): after the
// planned plates, the target side is up and the tip leads (|heading| < 90 degrees).
TEST(PlanFlips, EveryOrientationStateEndsTargetSideUpTipLeading) {
  for (SideUp target : {SideUp::kSkin, SideUp::kBone}) {
    for (Hand hand : {Hand::kLeft, Hand::kRight}) {
      for (SideUp seen : {SideUp::kSkin, SideUp::kBone}) {
        // 0.2 rad off the belt axis: the guiding rails align fillets, but not perfectly.
        for (float heading : {0.2F, -0.2F, kPi - 0.2F, -kPi + 0.2F}) {
          const FlipPlan plan = plan_flips(seen, heading, target);
          SideUp side = seen;
          float angle = heading;
          apply_plate(true, plan.plate1, side, angle);
          apply_plate(false, plan.plate2, side, angle);
          EXPECT_EQ(side, target) << "hand " << static_cast<int>(hand) << " heading " << heading;
          EXPECT_LT(std::fabs(angle), kPi / 2) << "heading " << heading;
          // The residual heading keeps its size: the multilane only has to turn it.
          EXPECT_NEAR(std::fabs(angle), 0.2F, 1e-5F);
        }
      }
    }
  }
}

TEST(ApplyPlate, EndOverEndMirrorsAboutTheLateralAxis) {
  SideUp side = SideUp::kSkin;
  float angle = 0.3F;
  apply_plate(true, true, side, angle);
  EXPECT_EQ(side, SideUp::kBone);
  EXPECT_NEAR(angle, kPi - 0.3F, 1e-6F);  // tip now points backwards, mirrored
}

TEST(ApplyPlate, SidewaysMirrorsAboutTheTravelAxis) {
  SideUp side = SideUp::kBone;
  float angle = 0.3F;
  apply_plate(false, true, side, angle);
  EXPECT_EQ(side, SideUp::kSkin);
  EXPECT_NEAR(angle, -0.3F, 1e-6F);
}

TEST(ApplyPlate, PlateInPlaceChangesNothing) {
  SideUp side = SideUp::kBone;
  float angle = 1.0F;
  apply_plate(true, false, side, angle);
  EXPECT_EQ(side, SideUp::kBone);
  EXPECT_EQ(angle, 1.0F);
}

// An item seen bone side up with the thick end leading, target skin: plate 1 alone.
TEST(FlipStation, ClassifiesAtDecisionPointAndCommandsPlates) {
  test::Harness h;
  h.config.flip.target_side = SideUp::kSkin;
  FlipStation station(h.config);
  Item* item = h.tracker.create(0, station.decision_s_mm() - 50.0F, false);
  ASSERT_NE(item, nullptr);
  item->evidence[index(CameraId::kOrientation)].add(
      test::good_estimate(Hand::kRight, SideUp::kBone, kPi - 0.1F));
  station.update(h.context(), h.out);
  EXPECT_FALSE(item->classified);  // not yet at the decision point

  item->s_mm = station.decision_s_mm() + 1.0F;
  station.update(h.context(), h.out);
  EXPECT_TRUE(item->classified);
  EXPECT_FALSE(item->reject_pending);
  EXPECT_TRUE(h.out.flip_plate1_flip);
  EXPECT_FALSE(h.out.flip_plate2_flip);
  EXPECT_EQ(h.counters.flip_conflicts, 0U);  // decided with a full actuation time to spare
}

TEST(FlipStation, TouchingPairIsFlaggedForTheRejectBelt) {
  test::Harness h;
  FlipStation station(h.config);
  Item* item = h.tracker.create(0, station.decision_s_mm() + 1.0F, false);
  FilletEstimate pair = test::good_estimate(Hand::kLeft, SideUp::kSkin, 0.0F);
  pair.singulated = false;
  item->evidence[index(CameraId::kOrientation)].add(pair);
  station.update(h.context(), h.out);
  EXPECT_TRUE(item->reject_pending);
  EXPECT_EQ(item->reject_reason, Outcome::kRejectedNotSingulated);
}

TEST(FlipStation, LowConfidenceIsRejectedAsUnclassified) {
  test::Harness h;
  FlipStation station(h.config);
  Item* item = h.tracker.create(0, station.decision_s_mm() + 1.0F, false);
  FilletEstimate unsure = test::good_estimate(Hand::kLeft, SideUp::kSkin, 0.0F);
  unsure.confidence = h.config.reject.min_confidence * 0.5F;
  item->evidence[index(CameraId::kOrientation)].add(unsure);
  station.update(h.context(), h.out);
  EXPECT_TRUE(item->reject_pending);
  EXPECT_EQ(item->reject_reason, Outcome::kRejectedUnclassified);
}

TEST(FlipStation, UnseenItemIsNotGuessed) {
  test::Harness h;
  FlipStation station(h.config);
  Item* item = h.tracker.create(0, station.decision_s_mm() + 1.0F, false);
  station.update(h.context(), h.out);
  EXPECT_TRUE(item->reject_pending);
  EXPECT_EQ(item->reject_reason, Outcome::kRejectedUnclassified);
}

// Left fillets are placed mirrored: -35 degrees.
TEST(FlipStation, LeftFilletGetsMirroredTarget) {
  test::Harness h;
  FlipStation station(h.config);
  Item* item = h.tracker.create(0, station.decision_s_mm() + 1.0F, false);
  item->evidence[index(CameraId::kOrientation)].add(
      test::good_estimate(Hand::kLeft, h.config.flip.target_side, 0.0F));
  station.update(h.context(), h.out);
  EXPECT_FLOAT_EQ(item->target_angle_rad, -h.config.tolerance.target_angle_rad);
}

}  // namespace
}  // namespace fl::logic
