// SPDX-License-Identifier: GPL-3.0-or-later
// GoogleTest main of the floating-point-trapping test configuration (cmake -DRBC_TRAP_FP=ON,
// STYLE.md 8): enables hardware traps before any test runs, so an invalid operation (the
// birth of a NaN: 0/0, inf - inf, sqrt(-1), ...) raises SIGFPE where it happens instead of
// propagating. OpenMP worker threads are created later and inherit the floating-point
// environment of the main thread.
//
// Which exceptions: FE_INVALID always. FE_DIVBYZERO and FE_OVERFLOW only when named in the
// environment variable RBC_FP_TRAPS (comma-separated: invalid, divbyzero, overflow), since
// +infinity is a legitimate value here: the WLC energy is +inf at and beyond Lmax and the
// line searches evaluate such states on purpose.
#include <gtest/gtest.h>

#include <cfenv>
#include <cstdlib>
#include <cstring>
#include <iostream>

int main(int argc, char** argv) {
  int excepts = FE_INVALID;
  if (const char* list = std::getenv("RBC_FP_TRAPS")) {
    excepts = 0;
    if (std::strstr(list, "invalid")) excepts |= FE_INVALID;
    if (std::strstr(list, "divbyzero")) excepts |= FE_DIVBYZERO;
    if (std::strstr(list, "overflow")) excepts |= FE_OVERFLOW;
  }
  std::feclearexcept(FE_ALL_EXCEPT);
  if (feenableexcept(excepts) == -1) {
    std::cerr << "fp_trap_main: feenableexcept failed\n";
    return 2;
  }
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
