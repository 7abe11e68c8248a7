// checked_touch: a reported touch on its search is passed on; off the line, before its start or past
// its end it is a Protocol fault that names the centre and how far off it lies.
#include <gtest/gtest.h>

#include <string>

#include "hal/fault.hpp"
#include "hal/touch_check.hpp"

namespace cmm::hal {
namespace {

ProbeMove search() {
  ProbeMove p;
  p.start = {10, 20, 30};
  p.direction = {1, 0, 0};
  p.max_travel_mm = 8;
  return p;
}

TouchResult touch_at(const Vec3& centre) {
  TouchResult t;
  t.contact = true;
  t.centre = centre;
  return t;
}

std::string refusal(const TouchResult& t) {
  try {
    checked_touch(search(), t, "the I++ DME machine");
  } catch (const Protocol& e) {
    return e.what();
  }
  return "";
}

TEST(TouchCheck, PassesATouchOnTheSearchWithinItsTolerance) {
  for (const Vec3& c : {Vec3{10, 20, 30}, Vec3{14, 20.009, 30}, Vec3{18.009, 20, 29.993}, Vec3{9.991, 20, 30}}) {
    const TouchResult t = checked_touch(search(), touch_at(c), "m");
    EXPECT_EQ(t.centre, c);
  }
}

TEST(TouchCheck, RefusesAReportOffTheLineOrBeyondEitherEnd) {
  EXPECT_NE(refusal(touch_at({14, 20.3, 30})).find("off the commanded search line by 0.300000 mm"), std::string::npos);
  EXPECT_NE(refusal(touch_at({14, 20, 30.011})).find("off the commanded search line"), std::string::npos);
  // 50 mm along the line: a point in the same plane as the true one, far past the search.
  const std::string far = refusal(touch_at({64, 20, 30}));
  EXPECT_NE(far.find("past the search's end by 46.000000 mm"), std::string::npos) << far;
  EXPECT_NE(far.find("the I++ DME machine reported a touch at (64.000000, 20.000000, 30.000000)"), std::string::npos)
      << far;
  EXPECT_NE(refusal(touch_at({9.98, 20, 30})).find("before the search's start"), std::string::npos);
  EXPECT_NE(refusal(touch_at({NAN, 20, 30})).find("not a number"), std::string::npos);
}

TEST(TouchCheck, AMissIsNotAContactAndIsPassedOn) {
  TouchResult miss;
  miss.centre = {100, 100, 100};
  EXPECT_FALSE(checked_touch(search(), miss, "m").contact);
}

}  // namespace
}  // namespace cmm::hal
