// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The inferred parameters of `rbc infer` and their uniform prior boxes, in the natural units
// of the command line (nm, J, dimensionless), with the parsers of --params and --prior.
// Dependency-free on purpose (the standard library only): a libFuzzer target links just it.
#include <string>
#include <vector>

namespace rbc {

/// A parameter the calibration may infer.
enum class Parameter {
  persistence,       ///< spectrin persistence length p (nm); Lbar stays 75 nm
  lmax,              ///< spectrin contour length Lmax (nm), > Lbar = 75 nm
  kappa,             ///< bending rigidity (J)
  contact_fraction,  ///< bead contact area per bead / total area (smooth patch weights)
  sigma_scale,       ///< factor on every error bar (dimensionless)
  eta_m,             ///< membrane viscosity (pN s/um = Pa s um); enters recovery data only
  tau,               ///< between-experiment sd of a per-experiment diameter offset (um)
  eta_spread,        ///< between-cell sd of log eta_m (dimensionless); recovery data only
};
inline constexpr int kParameterCount = 8;

/// CLI name: "persistence", "lmax", "kappa", "contact-fraction", "sigma-scale", "eta-m", "tau",
/// "eta-spread".
std::string to_string(Parameter p);
/// Unit at the CLI: "nm", "nm", "J", "1", "1", "pN s/um", "um", "1".
std::string unit_of(Parameter p);
/// Parses a CLI name; throws std::invalid_argument naming it and listing the known ones.
Parameter parameter_from_string(const std::string& name);
/// Parses "persistence,lmax,sigma-scale" (no repeats, at least one); throws
/// std::invalid_argument naming the bad or repeated item.
std::vector<Parameter> parse_parameter_list(const std::string& text);

/// A uniform prior lower < value < upper (natural units).
struct PriorRange {
  Parameter parameter = Parameter::persistence;
  double lower = 0, upper = 0;
  /// Throws std::invalid_argument naming the parameter and the box unless both bounds are
  /// finite, lower < upper and the box is physical (p > 0, Lmax > 75 nm, kappa > 0,
  /// contact fraction in (0, 0.5), sigma scale > 0, eta_m > 0, tau >= 0, eta-spread > 0).
  void validate() const;
};

/// Documented default boxes (natural units), wide around the paper's values (Table 1-2):
///   persistence 2:40 nm (paper 7.5; mu ~ 1/p, so 2.5 uN/m needs ~25 nm at Lmax 237.75),
///   lmax 150:300 nm (paper 237.75; x0 = Lbar/Lmax <= 0.5; above 300 nm with p > 30 nm the
///   cell stretches past 5 times its diameter at 193 pN, D_A > 40 um against the data's
///   16.3 um, where buckled soft cells converge slowly or not at all: measured at 2,000
///   elements, p = 40 nm with Lmax = 350 nm fails, p = 40 nm with 300 nm converges; the
///   equal-stiffness ridge of the Mills data reaches Lmax = 150 nm at p ~ 25 nm, inside the box),
///   kappa 5e-20:1e-18 J (paper 2e-19),
///   contact-fraction 0.02:0.15 (paper 0.05), sigma-scale 0.2:3,
///   eta-m 0.2:2 pN s/um (membrane viscosity; Hochmuth et al. 1979 report 0.6-1 pN s/um,
///   i.e. (0.6-1) x 1e-3 dyn s/cm),
///   tau 0:1 um (the between-experiment sd of calibrate/likelihood.hpp's hierarchical layer:
///   uniform from no offset to 1 um, twice the smallest error bar of the bundled stretch data),
///   eta-spread 0.01:1 (the sd s of log eta_m over recovery cells,
///   calibrate/recovery_likelihood.hpp: 0.01 is far below what 25 readings of a cell resolve, ~0.05
///   in log eta, so the lower edge is the shared-eta_m model in effect, while s > 0 keeps the
///   quadrature's width defined; 1 is a factor e per sd between cells, beyond the factor 1.5 that
///   the four Hochmuth cells span fitted one by one).
PriorRange default_prior(Parameter p);

/// Parses "NAME=LOWER:UPPER", e.g. "persistence=3:20" or "kappa=1e-19:5e-19"; throws
/// std::invalid_argument naming the text for a bad form, an unknown name, a non-numeric
/// bound, or an empty, inverted or non-physical box.
PriorRange parse_prior(const std::string& text);

}  // namespace rbc
