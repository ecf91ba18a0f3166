// Parameters: defaults agree with config/default.yaml, bad values are refused clearly.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>
#include <type_traits>

#include "novelty_detection/io/params_io.h"

using novelty_detection::Params;

namespace {
std::string readFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}
}  // namespace

TEST(Params, DefaultsAreValid) { EXPECT_NO_THROW(Params().validate()); }

TEST(Params, DefaultYamlMatchesStructDefaults) {
  // config/default.yaml is generated from the struct; a stale copy fails here.
  const std::string yaml = readFile(std::string(NOVELTY_SOURCE_DIR) + "/config/default.yaml");
  ASSERT_FALSE(yaml.empty());
  EXPECT_NE(yaml.find(novelty_detection::paramsToYaml(Params())), std::string::npos)
      << "config/default.yaml is out of date: regenerate it with print_params --yaml";
}

TEST(Params, ParameterDocMatchesStruct) {
  const std::string doc = readFile(std::string(NOVELTY_SOURCE_DIR) + "/docs/parameters.md");
  EXPECT_NE(doc.find(novelty_detection::paramsToMarkdown(Params())), std::string::npos)
      << "docs/parameters.md is out of date: run scripts/update_docs.sh";
}

// Every numeric field's stated range is enforced: just outside either bound, validate()
// refuses the value and names the field.
TEST(Params, EveryStatedRangeIsEnforced) {
  int checked = 0;
  Params(Params()).visit([&](const char* group, const char* name, auto& value,
                             const novelty_detection::ParamInfo& info) {
    using T = std::decay_t<decltype(value)>;
    if constexpr (std::is_arithmetic_v<T> && !std::is_same_v<T, bool>) {
      const std::string full = std::string(group) + "/" + name;
      ASSERT_TRUE(std::isfinite(info.min) && std::isfinite(info.max)) << full << " has no range";
      for (const double bound : {info.min, info.max}) {
        const bool is_min = bound == info.min;
        if (std::is_integral_v<T> && !is_min && bound >= double(std::numeric_limits<T>::max()))
          continue;  // the type itself is the bound
        const T step = std::is_integral_v<T> ? T(1) : T(std::max(1e-9, std::abs(bound) * 1e-6));
        Params p;
        bool found = false;
        p.visit([&](const char* g, const char* n, auto& v, const novelty_detection::ParamInfo&) {
          if constexpr (std::is_same_v<std::decay_t<decltype(v)>, T>) {
            if (std::string(g) + "/" + n == full) {
              v = static_cast<T>(bound) + (is_min ? -step : step);
              found = true;
            }
          }
        });
        ASSERT_TRUE(found) << full;
        try {
          p.validate();
          ADD_FAILURE() << full << " = " << bound << (is_min ? " - " : " + ") << step
                        << " was accepted";
        } catch (const std::invalid_argument& e) {
          EXPECT_NE(std::string(e.what()).find(full), std::string::npos) << e.what();
        }
      }
      ++checked;
    }
  });
  EXPECT_EQ(checked, 104);  // every int and double field of params.h
}

TEST(Params, DoublesAreWrittenAsYaml11Floats) {
  // rosparam parses YAML 1.1, where 1e-06 is a string; 1.0e-06 is a float.
  Params p;
  p.gmm.tolerance = 1e-6;
  const std::string yaml = novelty_detection::paramsToYaml(p);
  EXPECT_NE(yaml.find("tolerance: 1.0e-06"), std::string::npos) << yaml;
  Params q;
  novelty_detection::loadParamsYamlString(yaml, q);
  EXPECT_DOUBLE_EQ(q.gmm.tolerance, 1e-6);
}

TEST(Params, YamlOverridesAndRoundTrips) {
  Params p;
  novelty_detection::loadParamsYamlString("gmm:\n  max_components: 12\nselection:\n  u_th: 0.5\n",
                                          p);
  EXPECT_EQ(p.gmm.max_components, 12);
  EXPECT_DOUBLE_EQ(p.selection.u_th, 0.5);
  EXPECT_EQ(p.preprocess.outlier_k, Params().preprocess.outlier_k);
  Params q;
  novelty_detection::loadParamsYamlString(novelty_detection::paramsToYaml(p), q);
  EXPECT_EQ(q.gmm.max_components, 12);
  EXPECT_DOUBLE_EQ(q.selection.u_th, 0.5);
}

namespace {

/// Loading `yaml` into `p` is refused with a message containing `fragment`.
void expectRefused(Params& p, const std::string& yaml, const std::string& fragment) {
  try {
    novelty_detection::loadParamsYamlString(yaml, p);
    ADD_FAILURE() << "accepted: " << yaml;
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
  }
}

}  // namespace

TEST(Params, RejectsUnknownKeysWrongTypesAndRanges) {
  Params p;
  expectRefused(p, "gmm:\n  max_componentz: 3\n", "gmm/max_componentz");
  expectRefused(p, "gmmm:\n  max_components: 3\n", "gmmm");
  expectRefused(p, "gmm:\n  max_components: lots\n", "gmm/max_components");
  expectRefused(p, "gmm:\n  max_components: 0\n", "gmm/max_components");
  expectRefused(p, "selection:\n  ground_distance: manhattan\n", "selection/ground_distance");
  expectRefused(p, "superquadric:\n  epsilon_min: 1.5\n  epsilon_max: 1.0\n", "epsilon_min");
  // A refused file changes nothing.
  EXPECT_EQ(p.gmm.max_components, Params().gmm.max_components);
}

// A repeated key, a repeated group or a second YAML document would be read one way here
// (yaml-cpp answers with the first) and another by rosparam (the last): refused, with the
// name and line, and nothing applied.
TEST(Params, RepeatsAndSecondDocumentsAreRefused) {
  Params p;
  expectRefused(p, "gmm:\n  max_components: 3\n  max_components: 5\n",
                "parameter 'gmm/max_components' repeated (line 3)");
  expectRefused(p,
                "gmm:\n  max_components: 3\nselection:\n  u_th: 0.5\ngmm:\n  max_components: 5\n",
                "group 'gmm' repeated (line 5)");
  expectRefused(p, "gmm:\n  max_components: 3\n---\ngmm:\n  max_components: 5\n",
                "holds 2 YAML documents");
  EXPECT_EQ(p.gmm.max_components, Params().gmm.max_components);
  EXPECT_EQ(p.selection.u_th, Params().selection.u_th);
  // One document, each key once: applied.
  novelty_detection::loadParamsYamlString("---\ngmm:\n  max_components: 3\n", p);
  EXPECT_EQ(p.gmm.max_components, 3);
}

TEST(Params, MissingFileIsAClearError) {
  Params p;
  EXPECT_THROW(novelty_detection::loadParamsYaml("/nonexistent/x.yaml", p), std::invalid_argument);
}
