// SPDX-License-Identifier: GPL-3.0-or-later
// Must NOT compile (ctest layering.WrongDirectionIncludeFails, WILL_FAIL): a translation unit
// built with rbc_discrete's include path cannot see continuum/ headers.
#include "continuum/continuum_model.hpp"
int rbc_layering_probe() {
  return 0;
}
