// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The in-plane material as a user states it: spectrin lengths in nm, temperature in K,
// steric q and eta. Converted to internal units (um) once, here, for the sub-commands.
#include "core/defaults.hpp"
#include "core/units.hpp"
#include "discrete/steric_energy.hpp"
#include "discrete/wlc.hpp"

namespace rbc {

/// Defaults: Li et al. 2005 / Table 1 (Lbar 75 nm, Lmax 237.75 nm, p 7.5 nm, 300 K),
/// q = 1, eta = 0.005 (MODEL.md section 2).
struct MembraneInputs {
  double lbar_nm = defaults::kLbar_nm;
  double lmax_nm = defaults::kLmax_nm;
  double persistence_nm = defaults::kPersistence_nm;
  double temperature_K = defaults::kWlcTemperature_K;
  double q = 1.0;
  double eta = 0.005;
  /// Internal units, validated (throws std::invalid_argument naming the value).
  WlcParameters wlc() const {
    WlcParameters p{units::nm_to_um(lbar_nm), units::nm_to_um(lmax_nm),
                    units::nm_to_um(persistence_nm), temperature_K};
    p.validate();
    return p;
  }
  StericParameters steric() const {
    StericParameters s{q, eta};
    s.validate();
    return s;
  }
};

}  // namespace rbc
