#pragma once

// The message of the ardy::Error an action throws; fails the running Catch2
// test when it throws nothing or another exception type.

#include <catch_amalgamated.hpp>

#include <exception>
#include <functional>
#include <string>

#include "error.hpp"

namespace ardy_test {

inline std::string error_message(const std::function<void()>& action) {
  try {
    action();
  } catch (const ardy::Error& e) {
    return e.what();
  } catch (const std::exception& e) {
    FAIL("expected ardy::Error, got another exception: " << e.what());
  } catch (...) {
    FAIL("expected ardy::Error, got a non-standard exception");
  }
  FAIL("expected ardy::Error, nothing was thrown");
  return {};
}

}  // namespace ardy_test
