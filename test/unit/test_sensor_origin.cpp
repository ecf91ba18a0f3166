// The sensor-origin rule: stated, else the cloud's own frame, else the file's VIEWPOINT.
#include <gtest/gtest.h>

#include "novelty_detection/params.h"
#include "novelty_detection/preprocess/sensor_origin.h"

using namespace novelty_detection;

TEST(SensorOrigin, ParseStatedOrigins) {
  EXPECT_FALSE(parseOrigin("p", "").has_value());
  EXPECT_FALSE(parseOrigin("p", "  ").has_value());
  const auto o = parseOrigin("p", "1.5 -2 0.25");
  ASSERT_TRUE(o.has_value());
  EXPECT_EQ(*o, Eigen::Vector3f(1.5f, -2.0f, 0.25f));
  for (const char* bad : {"1 2", "1 2 3 4", "1 2 nan", "x y z", "1 2 1e9"}) {
    try {
      parseOrigin("preprocess/current_origin", bad);
      FAIL() << bad;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("preprocess/current_origin"), std::string::npos);
    }
  }
  Params p;
  p.preprocess.reference_origin = "0 0";
  EXPECT_THROW(p.validate(), std::invalid_argument);
  p.preprocess.reference_origin = "0 0 0";
  EXPECT_NO_THROW(p.validate());
}

TEST(SensorOrigin, PrecedenceGivenThenSensorFrameThenViewpoint) {
  Cloud c;
  c.push_back(PointT(1, 2, 3));
  c.sensor_origin_ << 4, 5, 6, 0;  // a file's VIEWPOINT
  Cloud a = c;
  EXPECT_EQ(resolveOrigin(a, Eigen::Vector3f(7, 8, 9), true), "given");
  EXPECT_EQ(a.sensor_origin_, Eigen::Vector4f(7, 8, 9, 1));
  Cloud b = c;
  EXPECT_EQ(resolveOrigin(b, std::nullopt, true), "sensor frame");
  EXPECT_TRUE(sensorOriginKnown(b.sensor_origin_));
  EXPECT_EQ(b.sensor_origin_.head<3>(), Eigen::Vector3f::Zero());
  Cloud v = c;
  EXPECT_EQ(resolveOrigin(v, std::nullopt, false), "viewpoint");
  EXPECT_EQ(v.sensor_origin_.head<3>(), Eigen::Vector3f(4, 5, 6));
  Cloud none;
  none.push_back(PointT(1, 2, 3));
  EXPECT_EQ(resolveOrigin(none, std::nullopt, false), "unknown");
  EXPECT_FALSE(sensorOriginKnown(none.sensor_origin_));
  Cloud organised;
  organised.resize(4);
  organised.width = 2;
  organised.height = 2;
  EXPECT_EQ(resolveOrigin(organised, std::nullopt, false), "sensor frame (organised cloud)");
}
