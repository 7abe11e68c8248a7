// Feature extraction hears a cancel between its steps and refuses a spacing that would give more
// points than its limit before doing the costly part (issue 13, D2 and D3).
#include <gtest/gtest.h>

#include <atomic>

#include "geometry/analytic_parts.hpp"
#include "geometry/feature_model.hpp"

namespace cmm::geometry {
namespace {

// Cancels once it has been asked `after` times; counts how often it was asked.
struct CancelAfter {
  int after;
  std::atomic<int> asked{0};
  CancelCheck check() {
    return {[this] { return ++asked > after; }};
  }
};

TEST(FeatureCancellation, ACancelStopsExtractionAtItsNextStep) {
  const TriangleMesh noisy = with_gaussian_noise(make_case3_block(1.0).mesh, 0.1, 7);
  // How often a whole extraction asks: the steps a cancel can stop at.
  CancelAfter never{1 << 30};
  FeatureModelOptions options;
  options.cancel = never.check();
  const FeatureModel model = extract_features(noisy, options);
  EXPECT_FALSE(model.points.empty());
  const int steps = never.asked.load();
  EXPECT_GE(steps, 15) << "too few places where a cancel is heard";
  // A cancel at each of a spread of those steps ends the extraction there, with Cancelled.
  for (int at : {0, 1, 2, 5, steps / 2, steps - 1}) {
    CancelAfter cancel{at};
    options.cancel = cancel.check();
    EXPECT_THROW(extract_features(noisy, options), Cancelled) << "cancelled at step " << at;
    EXPECT_EQ(cancel.asked.load(), at + 1) << "went on asking after it was cancelled";
  }
}

TEST(FeatureCancellation, TooManyPointsIsRefusedBeforeTheyAreMade) {
  const TriangleMesh block = make_case3_block(1.0).mesh;
  FeatureModelOptions options;
  options.spacing = 0.01;
  options.max_points = 20000;
  CancelAfter counter{1 << 30};
  options.cancel = counter.check();
  try {
    extract_features(block, options);
    FAIL() << "a spacing of 0.01 mm on the case-3 block was planned";
  } catch (const TooManyPoints& e) {
    EXPECT_GT(e.points, 100'000u);  // its curves are about 1.4 m long
    EXPECT_EQ(e.limit, 20000u);
    EXPECT_NE(std::string(e.what()).find("coarser spacing"), std::string::npos) << e.what();
  }
  // Refused after the feature curves are known and before any curve is sampled.
  EXPECT_LE(counter.asked.load(), 4);
  options.spacing = 2;
  EXPECT_NO_THROW(extract_features(block, options));
}

}  // namespace
}  // namespace cmm::geometry
