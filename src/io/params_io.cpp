#include "novelty_detection/io/params_io.h"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>
#include <iomanip>
#include <set>
#include <sstream>
#include <type_traits>
#include <vector>

namespace novelty_detection {
namespace {

template <class T>
const char* typeName() {
  if constexpr (std::is_same_v<T, bool>) return "bool";
  if constexpr (std::is_same_v<T, int>) return "int";
  if constexpr (std::is_same_v<T, double>) return "double";
  return "string";
}

template <class T>
std::string valueToString(const T& value) {
  std::ostringstream out;
  if constexpr (std::is_same_v<T, bool>) {
    out << (value ? "true" : "false");
  } else if constexpr (std::is_same_v<T, double>) {
    out << std::setprecision(10) << value;
    std::string s = out.str();
    // YAML 1.1 (rosparam) reads a float only with a dot: 1e-06 must be 1.0e-06.
    if (s.find_first_of("ni") != std::string::npos) return s;  // nan, inf
    if (s.find('.') == std::string::npos) {
      const auto e = s.find('e');
      if (e == std::string::npos) return s + ".0";
      s.insert(e, ".0");
    }
    return s;
  } else if constexpr (std::is_same_v<T, std::string>) {
    if (value.empty()) return "\"\"";  // not YAML's null
    out << value;
  } else {
    out << value;
  }
  return out.str();
}

// "[min, max]" of a numeric field in its own type; empty for bool and string fields.
template <class T>
std::string rangeToString(const ParamInfo& info) {
  if constexpr (std::is_arithmetic_v<T> && !std::is_same_v<T, bool>) {
    auto bound = [](double b) {
      if (!std::isfinite(b)) return std::string(b < 0 ? "-inf" : "inf");
      return valueToString(static_cast<T>(b));
    };
    return "[" + bound(info.min) + ", " + bound(info.max) + "]";
  }
  return "";
}

// Applies the overrides to a copy, so `out` is untouched when anything is wrong.
void applyYaml(const YAML::Node& root, const std::string& where, Params& out) {
  Params params = out;
  if (!root || root.IsNull()) {
    params.validate();
    return;
  }
  if (!root.IsMap()) throw std::invalid_argument(where + ": top level must be a map of groups");
  std::set<std::string> groups, known;
  params.visit([&](const char* group, const char* name, auto&, const ParamInfo&) {
    groups.insert(group);
    known.insert(std::string(group) + "/" + name);
  });
  // yaml-cpp keeps every repeated key and answers lookups with the first, rosparam with the
  // last: a repeat would configure the tool and the node differently, so it is refused.
  auto line = [](const YAML::Node& n) { return std::to_string(n.Mark().line + 1); };
  std::set<std::string> seen_groups, seen_keys;
  for (const auto& g : root) {
    const std::string group = g.first.as<std::string>();
    if (!groups.count(group))
      throw std::invalid_argument(where + ": unknown group '" + group + "'");
    if (!seen_groups.insert(group).second)
      throw std::invalid_argument(where + ": group '" + group + "' repeated (line " +
                                  line(g.first) + "); give each group once");
    if (!g.second.IsMap())
      throw std::invalid_argument(where + ": group '" + group + "' must be a map");
    for (const auto& kv : g.second) {
      const std::string key = group + "/" + kv.first.as<std::string>();
      if (!known.count(key))
        throw std::invalid_argument(where + ": unknown parameter '" + key + "'");
      if (!seen_keys.insert(key).second)
        throw std::invalid_argument(where + ": parameter '" + key + "' repeated (line " +
                                    line(kv.first) + "); give each parameter once");
    }
  }
  params.visit([&](const char* group, const char* name, auto& value, const ParamInfo&) {
    using T = std::decay_t<decltype(value)>;
    const YAML::Node g = root[group];
    if (!g) return;
    const YAML::Node node = g[name];
    if (!node) return;
    try {
      if constexpr (std::is_same_v<T, std::string>) {
        if (node.IsNull()) {  // `key:` or `key: ~`: not set
          value.clear();
          return;
        }
      }
      value = node.as<T>();
    } catch (const YAML::Exception&) {
      throw std::invalid_argument(where + ": parameter " + group + "/" + name +
                                  " must be of type " + typeName<T>());
    }
  });
  params.validate();
  out = params;
}

}  // namespace

namespace {

/// The one document of a YAML text (null when empty); more than one is refused.
YAML::Node singleDocument(const std::vector<YAML::Node>& documents, const std::string& where) {
  if (documents.size() > 1)
    throw std::invalid_argument(where + " holds " + std::to_string(documents.size()) +
                                " YAML documents (separated by '---'); put every setting in one");
  return documents.empty() ? YAML::Node() : documents.front();
}

}  // namespace

void loadParamsYaml(const std::string& path, Params& params) {
  YAML::Node root;
  try {
    root = singleDocument(YAML::LoadAllFromFile(path), "config file '" + path + "'");
  } catch (const YAML::BadFile&) {
    throw std::invalid_argument("cannot read config file '" + path + "'");
  } catch (const YAML::Exception& e) {
    throw std::invalid_argument("config file '" + path + "' is not valid YAML: " + e.msg);
  }
  applyYaml(root, "config file '" + path + "'", params);
}

void loadParamsYamlString(const std::string& yaml, Params& params) {
  YAML::Node root;
  try {
    root = singleDocument(YAML::LoadAll(yaml), "config");
  } catch (const YAML::Exception& e) {
    throw std::invalid_argument("config is not valid YAML: " + e.msg);
  }
  applyYaml(root, "config", params);
}

std::string paramsToYaml(Params params) {
  std::ostringstream out;
  std::string current;
  params.visit([&](const char* group, const char* name, auto& value, const ParamInfo& info) {
    if (current != group) {
      if (!current.empty()) out << "\n";
      out << group << ":\n";
      current = group;
    }
    using T = std::decay_t<decltype(value)>;
    out << "  # " << info.doc << "\n";
    const std::string range = rangeToString<T>(info);
    if (!range.empty()) out << "  # range: " << range << "\n";
    out << "  " << name << ": " << valueToString(value) << "\n";
  });
  return out.str();
}

std::string paramsToMarkdown(Params params) {
  std::ostringstream out;
  out << "| name | type | default | range | meaning |\n|---|---|---|---|---|\n";
  params.visit([&](const char* group, const char* name, auto& value, const ParamInfo& info) {
    using T = std::decay_t<decltype(value)>;
    out << "| `" << group << "/" << name << "` | " << typeName<T>() << " | `"
        << valueToString(value) << "` | " << rangeToString<T>(info) << " | " << info.doc << " |\n";
  });
  return out.str();
}

}  // namespace novelty_detection
