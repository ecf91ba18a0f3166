// Parameters: defaults agree with config/default.yaml, bad values are refused clearly.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "novelty_detection/params_io.h"

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

TEST(Params, ReadmeTableMatchesStructDefaults) {
  const std::string readme = readFile(std::string(NOVELTY_SOURCE_DIR) + "/README.md");
  EXPECT_NE(readme.find(novelty_detection::paramsToMarkdown(Params())), std::string::npos)
      << "README.md's parameter table is out of date: run scripts/update_docs.sh";
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

TEST(Params, RejectsUnknownKeysWrongTypesAndRanges) {
  Params p;
  auto expectError = [&](const std::string& yaml, const std::string& fragment) {
    try {
      novelty_detection::loadParamsYamlString(yaml, p);
      ADD_FAILURE() << "accepted: " << yaml;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
    }
  };
  expectError("gmm:\n  max_componentz: 3\n", "gmm/max_componentz");
  expectError("gmmm:\n  max_components: 3\n", "gmmm");
  expectError("gmm:\n  max_components: lots\n", "gmm/max_components");
  expectError("gmm:\n  max_components: 0\n", "gmm/max_components");
  expectError("selection:\n  ground_distance: manhattan\n", "selection/ground_distance");
  expectError("superquadric:\n  epsilon_min: 1.5\n  epsilon_max: 1.0\n", "epsilon_min");
  // A refused file changes nothing.
  EXPECT_EQ(p.gmm.max_components, Params().gmm.max_components);
}

TEST(Params, MissingFileIsAClearError) {
  Params p;
  EXPECT_THROW(novelty_detection::loadParamsYaml("/nonexistent/x.yaml", p), std::invalid_argument);
}
