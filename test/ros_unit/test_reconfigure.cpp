// dynamic_reconfigure <-> Params bridge: names map group_name -> group/name, values are
// validated, refused updates change nothing.
#include <gtest/gtest.h>

#include <string>
#include <type_traits>

#include "novelty_detection/DetectorConfig.h"
#include "novelty_detection/ros/reconfigure.h"

using novelty_detection::DetectorConfig;
using novelty_detection::Params;

namespace {
dynamic_reconfigure::Config defaultMsg() {
  dynamic_reconfigure::Config msg;
  DetectorConfig::__getDefault__().__toMessage__(msg);
  return msg;
}
}  // namespace

TEST(Reconfigure, CfgDefaultsAreTheCoreDefaults) {
  // Detector.cfg reads its defaults from default.yaml: applying them changes nothing.
  const Params p = novelty_detection::applyConfigMsg(defaultMsg(), Params());
  const Params d;
  EXPECT_DOUBLE_EQ(p.selection.min_relative_decrease, d.selection.min_relative_decrease);
  EXPECT_DOUBLE_EQ(p.segmentation.novelty_distance_factor, d.segmentation.novelty_distance_factor);
  EXPECT_EQ(p.segmentation.min_segment_points, d.segmentation.min_segment_points);
  EXPECT_EQ(p.superquadric.enabled, d.superquadric.enabled);
}

TEST(Reconfigure, ValuesMapToTheirParameters) {
  dynamic_reconfigure::Config msg = defaultMsg();
  for (auto& e : msg.ints) {
    if (e.name == "segmentation_min_segment_points") e.value = 77;
  }
  for (auto& e : msg.doubles) {
    if (e.name == "segmentation_posterior_threshold") e.value = 0.25;
  }
  for (auto& e : msg.bools) {
    if (e.name == "superquadric_enabled") e.value = false;
  }
  const Params p = novelty_detection::applyConfigMsg(msg, Params());
  EXPECT_EQ(p.segmentation.min_segment_points, 77);
  EXPECT_DOUBLE_EQ(p.segmentation.posterior_threshold, 0.25);
  EXPECT_FALSE(p.superquadric.enabled);
  // Untouched parameters keep the values passed in.
  Params base;
  base.gmm.max_components = 5;
  EXPECT_EQ(novelty_detection::applyConfigMsg(msg, base).gmm.max_components, 5);

  // And back: the message shows what the parameters hold.
  Params q;
  q.segmentation.min_segment_points = 31;
  dynamic_reconfigure::Config out = defaultMsg();
  novelty_detection::paramsToConfigMsg(q, out);
  int shown = -1;
  for (const auto& e : out.ints) {
    if (e.name == "segmentation_min_segment_points") shown = e.value;
  }
  EXPECT_EQ(shown, 31);
}

TEST(Reconfigure, InvalidValuesAndUnknownNamesAreRefused) {
  dynamic_reconfigure::Config msg = defaultMsg();
  for (auto& e : msg.ints) {
    if (e.name == "segmentation_min_segment_points") e.value = 0;  // must be >= 1
  }
  EXPECT_THROW(novelty_detection::applyConfigMsg(msg, Params()), std::invalid_argument);
  dynamic_reconfigure::Config unknown = defaultMsg();
  dynamic_reconfigure::IntParameter extra;
  extra.name = "selection_no_such_thing";
  extra.value = 1;
  unknown.ints.push_back(extra);
  EXPECT_THROW(novelty_detection::applyConfigMsg(unknown, Params()), std::invalid_argument);
}

TEST(Reconfigure, CfgRangesAndDescriptionsAreTheCoreOnes) {
  // Detector.cfg reads ranges and descriptions from default.yaml too: every numeric entry's
  // min and max are the ones params.h states for that parameter.
  dynamic_reconfigure::Config lo, hi;
  DetectorConfig::__getMin__().__toMessage__(lo);
  DetectorConfig::__getMax__().__toMessage__(hi);
  int checked = 0;
  Params().visit([&](const char* group, const char* name, auto& value,
                     const novelty_detection::ParamInfo& info) {
    using T = std::decay_t<decltype(value)>;
    const std::string key = std::string(group) + "_" + name;
    auto check = [&](const auto& mins, const auto& maxs) {
      for (std::size_t i = 0; i < mins.size(); ++i) {
        if (mins[i].name != key) continue;
        EXPECT_DOUBLE_EQ(static_cast<double>(mins[i].value), info.min) << key;
        EXPECT_DOUBLE_EQ(static_cast<double>(maxs[i].value), info.max) << key;
        ++checked;
      }
    };
    if constexpr (std::is_same_v<T, int>) check(lo.ints, hi.ints);
    if constexpr (std::is_same_v<T, double>) check(lo.doubles, hi.doubles);
  });
  EXPECT_EQ(checked, 6);  // the numeric tunables of Detector.cfg
  for (const auto& d : DetectorConfig::__getParamDescriptions__())
    EXPECT_FALSE(d->description.empty());
}
