// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Internal units: length um, force pN, energy pN*um (= 1e-18 J), time s.
// Derived: moduli pN/um (= uN/m), pressure pN/um^2 (= Pa), bending rigidity pN*um.
// Physical inputs arrive in natural units (nm, J, kBT, K) and are converted here, once.

namespace rbc::units {

inline constexpr double kBoltzmann_J_per_K = 1.38e-23;  // MODEL.md, as in the paper
inline constexpr double pNum_per_J = 1.0e18;            // 1 pN*um = 1e-18 J
inline constexpr double um_per_nm = 1.0e-3;
inline constexpr double uN_per_m_per_pN_per_um = 1.0;  // 1 pN/um = 1 uN/m
inline constexpr double pi = 3.14159265358979323846;
inline constexpr double sqrt3 = 1.73205080756887729353;

/// Thermal energy kB*T in pN*um for a temperature in K (300 K -> 4.14e-3 pN*um).
constexpr double thermal_energy_pNum(double temperature_K) {
  return kBoltzmann_J_per_K * temperature_K * pNum_per_J;
}
/// Length in nm -> um.
constexpr double nm_to_um(double length_nm) {
  return length_nm * um_per_nm;
}
/// Energy in J -> pN*um (kappa = 2e-19 J -> 0.2 pN*um).
constexpr double joule_to_pNum(double energy_J) {
  return energy_J * pNum_per_J;
}
/// Energy in units of kB*T at temperature T -> pN*um.
constexpr double kbt_to_pNum(double energy_kBT, double temperature_K) {
  return energy_kBT * thermal_energy_pNum(temperature_K);
}

}  // namespace rbc::units
