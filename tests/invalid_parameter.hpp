// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The refusal a library's validation gives (core/validation.hpp), for tests of its limits.
#include <gtest/gtest.h>

#include <functional>
#include <string>

#include "core/validation.hpp"

namespace rbc::testing {

/// The message of the InvalidParameter f throws ("" and a test failure when none).
inline std::string limit_refusal(const std::function<void()>& f) {
  try {
    f();
  } catch (const InvalidParameter& e) {
    return e.what();
  }
  ADD_FAILURE() << "no InvalidParameter thrown";
  return "";
}

}  // namespace rbc::testing
