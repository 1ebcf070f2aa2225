// SPDX-License-Identifier: GPL-3.0-or-later
// Every default defined once: the library's internal-unit defaults are the natural-
// unit constants of core/defaults.hpp through the one conversion, so a front end converting a
// user's (default) nm/J input gets the same bits as a library user taking the struct defaults.
#include <gtest/gtest.h>

#include "core/defaults.hpp"
#include "core/units.hpp"
#include "discrete/bending_energy.hpp"
#include "homogenise/membrane_inputs.hpp"

namespace rbc {
namespace {

TEST(Defaults, FrontEndConversionGivesTheLibraryDefaultsBitForBit) {
  const WlcParameters lib;
  const WlcParameters cli = MembraneInputs{}.wlc();  // what `rbc moduli` / `rbc psi` convert
  EXPECT_EQ(cli.lbar_um, lib.lbar_um);
  EXPECT_EQ(cli.lmax_um, lib.lmax_um);
  EXPECT_EQ(cli.persistence_um, lib.persistence_um);
  EXPECT_EQ(cli.temperature_K, lib.temperature_K);
  EXPECT_EQ(BendingParameters{}.kappa_pNum, units::joule_to_pNum(defaults::kKappa_J));
  // The values are Table 1/2's (to round-off): Lmax = 3.17 Lbar, kappa = 0.2 pN um.
  EXPECT_NEAR(lib.lmax_um, 0.23775, 1e-15);
  EXPECT_NEAR(lib.lmax_um / lib.lbar_um, 3.17, 1e-12);
  EXPECT_NEAR(BendingParameters{}.kappa_pNum, 0.2, 1e-15);
}

}  // namespace
}  // namespace rbc
