// What a user reads for a caught exception: the standard library's own texts
// ("std::bad_alloc", "vector::_M_default_append") never reach a message alone.
#pragma once

#include <exception>
#include <new>
#include <stdexcept>
#include <string>

namespace novelty_detection {

inline std::string errorText(const std::exception& e) {
  if (dynamic_cast<const std::bad_alloc*>(&e) != nullptr) {
    return "out of memory: the input is larger than this machine can process (lower "
           "preprocess/max_points to refuse such clouds when they are read)";
  }
  if (dynamic_cast<const std::length_error*>(&e) != nullptr) {
    return std::string("a size beyond what this machine can hold (") + e.what() +
           "; lower preprocess/max_points)";
  }
  return e.what();
}

}  // namespace novelty_detection
