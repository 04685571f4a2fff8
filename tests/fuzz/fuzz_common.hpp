#pragma once

// What every harness shares: the test data, and the rule that an ardy::Error
// is the runtime refusing bad input (expected), while anything else escaping
// a harness (another exception, a crash, a sanitizer report) is a finding.

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <string>

#include "error.hpp"

namespace ardy_fuzz {

inline std::string data_path(const std::string& relative) { return std::string(ARDY_TEST_DATA_DIR) + "/" + relative; }

inline std::string read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    std::fprintf(stderr, "fuzz: cannot read %s\n", path.c_str());
    std::abort();
  }
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// Runs `f`; an ardy::Error is an ordinary refusal, every other exception
// propagates (libFuzzer reports it as a crash with its stack).
template <typename F>
void refusals_allowed(F&& f) {
  try {
    f();
  } catch (const ardy::Error&) {
  }
}

// An invariant the runtime promises, broken: a finding.
[[noreturn]] inline void broken(const std::string& what) {
  std::fprintf(stderr, "fuzz: invariant broken: %s\n", what.c_str());
  std::abort();
}

}  // namespace ardy_fuzz
