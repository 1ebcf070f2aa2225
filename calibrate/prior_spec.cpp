// SPDX-License-Identifier: GPL-3.0-or-later
#include "calibrate/prior_spec.hpp"

#include <cmath>
#include <cstdio>
#include <optional>
#include <stdexcept>

#include "core/validation.hpp"

namespace rbc {

namespace {
constexpr Parameter kAll[kParameterCount] = {
    Parameter::persistence, Parameter::lmax,  Parameter::kappa, Parameter::contact_fraction,
    Parameter::sigma_scale, Parameter::eta_m, Parameter::tau,   Parameter::eta_spread};
/// Spectrin rest link length (nm) the discrete and continuum models keep fixed.
constexpr double kLbarNm = 75.0;

std::string known_names() {
  std::string s;
  for (Parameter p : kAll) s += (s.empty() ? "" : ", ") + to_string(p);
  return s;
}

double parse_bound(const std::string& s, const std::string& text) {
  const std::optional<double> v = parse_finite_number(s);
  if (!v) throw std::invalid_argument("--prior '" + text + "': '" + s + "' is not a finite number");
  return *v;
}

std::string number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}
}  // namespace

std::string to_string(Parameter p) {
  switch (p) {
    case Parameter::persistence:
      return "persistence";
    case Parameter::lmax:
      return "lmax";
    case Parameter::kappa:
      return "kappa";
    case Parameter::contact_fraction:
      return "contact-fraction";
    case Parameter::sigma_scale:
      return "sigma-scale";
    case Parameter::eta_m:
      return "eta-m";
    case Parameter::tau:
      return "tau";
    case Parameter::eta_spread:
      return "eta-spread";
  }
  return "unknown";
}

std::string unit_of(Parameter p) {
  switch (p) {
    case Parameter::persistence:
    case Parameter::lmax:
      return "nm";
    case Parameter::kappa:
      return "J";
    case Parameter::eta_m:
      return "pN s/um";
    case Parameter::tau:
      return "um";
    default:
      return "1";
  }
}

Parameter parameter_from_string(const std::string& name) {
  for (Parameter p : kAll)
    if (to_string(p) == name) return p;
  throw std::invalid_argument("unknown parameter '" + name + "' (known: " + known_names() + ")");
}

std::vector<Parameter> parse_parameter_list(const std::string& text) {
  std::vector<Parameter> out;
  size_t start = 0;
  while (true) {
    const size_t comma = text.find(',', start);
    const std::string item =
        text.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    const Parameter p = parameter_from_string(item);
    for (Parameter q : out)
      if (q == p) throw std::invalid_argument("--params: '" + item + "' is given twice");
    out.push_back(p);
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return out;
}

void PriorRange::validate() const {
  const std::string box = to_string(parameter) + "=" + number(lower) + ":" + number(upper);
  if (!std::isfinite(lower) || !std::isfinite(upper) || !(lower < upper))
    throw std::invalid_argument("prior " + box + " is empty or inverted: needs lower < upper");
  const auto need = [&](bool ok, const std::string& what) {
    if (!ok) throw std::invalid_argument("prior " + box + " is not physical: " + what);
  };
  switch (parameter) {
    case Parameter::persistence:
      need(lower > 0, "persistence length must be > 0 nm");
      break;
    case Parameter::lmax:
      need(lower > kLbarNm, "Lmax must exceed Lbar = 75 nm");
      break;
    case Parameter::kappa:
      need(lower > 0, "bending rigidity must be > 0 J");
      break;
    case Parameter::contact_fraction:
      need(lower > 0 && upper < 0.5, "contact fraction must lie in (0, 0.5)");
      break;
    case Parameter::sigma_scale:
      need(lower > 0, "sigma scale must be > 0");
      break;
    case Parameter::eta_m:
      need(lower > 0, "membrane viscosity must be > 0 pN s/um");
      break;
    case Parameter::tau:
      need(lower >= 0, "between-experiment sd tau must be >= 0 um");
      break;
    case Parameter::eta_spread:
      need(lower > 0, "between-cell sd of log eta_m must be > 0");
      break;
  }
}

PriorRange default_prior(Parameter p) {
  switch (p) {
    case Parameter::persistence:
      return {p, 2.0, 40.0};
    case Parameter::lmax:
      return {p, 150.0, 300.0};
    case Parameter::kappa:
      return {p, 5e-20, 1e-18};
    case Parameter::contact_fraction:
      return {p, 0.02, 0.15};
    case Parameter::sigma_scale:
      return {p, 0.2, 3.0};
    case Parameter::eta_m:
      return {p, 0.2, 2.0};
    case Parameter::tau:
      return {p, 0.0, 1.0};
    case Parameter::eta_spread:
      return {p, 0.01, 1.0};
  }
  return {p, 0, 1};
}

PriorRange parse_prior(const std::string& text) {
  const size_t eq = text.find('=');
  const size_t colon = eq == std::string::npos ? std::string::npos : text.find(':', eq);
  if (eq == std::string::npos || colon == std::string::npos)
    throw std::invalid_argument("--prior '" + text + "' is not of the form NAME=LOWER:UPPER");
  PriorRange r;
  r.parameter = parameter_from_string(text.substr(0, eq));
  r.lower = parse_bound(text.substr(eq + 1, colon - eq - 1), text);
  r.upper = parse_bound(text.substr(colon + 1), text);
  r.validate();
  return r;
}

}  // namespace rbc
