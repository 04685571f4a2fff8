#pragma once

// The runtime library's one exception type. Thrown only inside the library;
// every public boundary (C ABI, Godot node, CLI) turns it into a message.

#include <stdexcept>

namespace ardy {

// Messages say what was wrong and where, e.g. "vocab.txt: line 12 is empty"
// or "skeleton: unknown joint 'Hand' (joints: Hips, Spine, ...)".
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace ardy
