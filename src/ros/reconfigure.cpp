#include "novelty_detection/ros/reconfigure.h"

#include <set>
#include <stdexcept>
#include <string>
#include <type_traits>

namespace novelty_detection {
namespace {

template <class Entries>
auto* findEntry(Entries& entries, const std::string& key) {
  for (auto& e : entries) {
    if (e.name == key) return &e;
  }
  return static_cast<decltype(&entries[0])>(nullptr);
}

}  // namespace

void paramsToConfigMsg(Params params, dynamic_reconfigure::Config& msg) {
  params.visit([&](const char* group, const char* name, auto& value, const ParamInfo&) {
    using T = std::decay_t<decltype(value)>;
    const std::string key = std::string(group) + "_" + name;
    if constexpr (std::is_same_v<T, bool>) {
      if (auto* e = findEntry(msg.bools, key)) e->value = value;
    } else if constexpr (std::is_same_v<T, int>) {
      if (auto* e = findEntry(msg.ints, key)) e->value = value;
    } else if constexpr (std::is_same_v<T, double>) {
      if (auto* e = findEntry(msg.doubles, key)) e->value = value;
    } else {
      if (auto* e = findEntry(msg.strs, key)) e->value = value;
    }
  });
}

Params applyConfigMsg(const dynamic_reconfigure::Config& msg, Params params) {
  std::set<std::string> used;
  params.visit([&](const char* group, const char* name, auto& value, const ParamInfo&) {
    using T = std::decay_t<decltype(value)>;
    const std::string key = std::string(group) + "_" + name;
    auto take = [&](const auto& entries) {
      for (const auto& e : entries) {
        if (e.name == key) {
          value = static_cast<T>(e.value);
          used.insert(key);
        }
      }
    };
    if constexpr (std::is_same_v<T, bool>) {
      take(msg.bools);
    } else if constexpr (std::is_same_v<T, int>) {
      take(msg.ints);
    } else if constexpr (std::is_same_v<T, double>) {
      take(msg.doubles);
    } else {
      take(msg.strs);
    }
  });
  auto check = [&](const auto& entries) {
    for (const auto& e : entries) {
      if (!used.count(e.name) && e.name != "groups") {
        throw std::invalid_argument("reconfigure entry '" + e.name + "' names no parameter");
      }
    }
  };
  check(msg.bools);
  check(msg.ints);
  check(msg.doubles);
  check(msg.strs);
  params.validate();
  return params;
}

}  // namespace novelty_detection
