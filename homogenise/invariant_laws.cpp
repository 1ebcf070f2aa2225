// SPDX-License-Identifier: GPL-3.0-or-later
#include "homogenise/invariant_laws.hpp"

#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <vector>

#include "core/units.hpp"
#include "homogenise/density_derivatives.hpp"

namespace rbc {
namespace {

/// G(a, B) and its derivatives (see the header).
struct AverageDerivatives {
  double g = 0, ga = 0, gb = 0, gaa = 0, gab = 0, gbb = 0;
};

/// Psi = 3 G(a, B) + s(J) with a = I2/2, B = (I2 + 2)^2/4 - J^2, J = 1 + I1, chained to
/// (I1, I2): B_1 = -2J, B_2 = (I2 + 2)/2, B_11 = -2, B_22 = 1/2, B_12 = 0, a_2 = 1/2.
InvariantDerivatives chain_to_invariants(const AverageDerivatives& g, const StericDensity& st,
                                         double i1, double i2) {
  const double b1 = -2.0 * (1.0 + i1), b2 = 0.5 * (i2 + 2.0);
  InvariantDerivatives r;
  r.psi = 3.0 * g.g + st.v;
  r.d1 = 3.0 * g.gb * b1 + st.dv;
  r.d2 = 3.0 * (0.5 * g.ga + g.gb * b2);
  r.d11 = 3.0 * (g.gbb * b1 * b1 - 2.0 * g.gb) + st.d2v;
  r.d12 = 3.0 * (0.5 * g.gab * b1 + g.gbb * b1 * b2);
  r.d22 = 3.0 * (0.25 * g.gaa + g.gab * b2 + g.gbb * b2 * b2 + 0.5 * g.gb);
  return r;
}

InvariantDerivatives outside() {
  InvariantDerivatives r;
  r.psi = std::numeric_limits<double>::infinity();
  return r;
}

/// Prepared state of one law: density, steric data and (full law) trapezoid tables.
struct LawState {
  WlcDensity w;
  StericParameters steric;
  double C = 0;
  /// Node tables for K = 16, 32, ..., 1024 midpoints t_k = (k + 1/2) pi / K on (0, pi):
  /// cos t_k and sin^2 t_k.
  std::vector<std::vector<double>> cos_t, sin2_t;
};

/// Polynomial Taylor law: G = sum_j c_j [a^j + j(j-1)/4 a^(j-2) B + j(j-1)(j-2)(j-3)/64 a^(j-4)
/// B^2].
AverageDerivatives taylor_average(const WlcDensity& w, int order, double a, double B) {
  // Integer powers a^0..a^4 (no std::pow: this runs at every quadrature point).
  const std::array<double, 5> pw{1.0, a, a * a, a * a * a, a * a * a * a};
  // value, first and second a-derivative of coef * a^k (zero for k < 0).
  auto mono = [&pw](double coef, int k, double& v, double& d, double& dd) {
    v = d = dd = 0.0;
    if (k < 0 || coef == 0.0) return;
    v = coef * pw[k];
    if (k >= 1) d = coef * k * pw[k - 1];
    if (k >= 2) dd = coef * k * (k - 1) * pw[k - 2];
  };
  AverageDerivatives g;
  for (int j = 0; j <= order; ++j) {
    const double c = w.taylor[j];
    double v0, d0, dd0, v1, d1, dd1, v2, d2, dd2;
    mono(c, j, v0, d0, dd0);
    mono(c * j * (j - 1) / 4.0, j - 2, v1, d1, dd1);
    mono(c * j * (j - 1) * (j - 2) * (j - 3) / 64.0, j - 4, v2, d2, dd2);
    g.g += v0 + v1 * B + v2 * B * B;
    g.ga += d0 + d1 * B + d2 * B * B;
    g.gaa += dd0 + dd1 * B + dd2 * B * B;
    g.gb += v1 + 2.0 * v2 * B;
    g.gab += d1 + 2.0 * d2 * B;
    g.gbb += 2.0 * v2;
  }
  return g;
}

int expansion_order(WlcExpansion e) {
  switch (e) {
    case WlcExpansion::order2:
      return 2;
    case WlcExpansion::order3:
      return 3;
    case WlcExpansion::order4:
      return 4;
    case WlcExpansion::full:
      break;
  }
  return 0;
}

InvariantDerivatives evaluate_taylor(const LawState& st, int order, double i1, double i2) {
  const double J = 1.0 + i1;
  if (!(J > 0.0)) return outside();
  const double a = 0.5 * i2, B = 0.25 * (i2 + 2.0) * (i2 + 2.0) - J * J;
  return chain_to_invariants(taylor_average(st.w, order, a, B), steric_density(st.C, st.steric, J),
                             i1, i2);
}

InvariantDerivatives evaluate_full(const LawState& st, double i1, double i2) {
  const double J = 1.0 + i1;
  if (!(J > 0.0)) return outside();
  const double a = 0.5 * i2;
  const double B = 0.25 * (i2 + 2.0) * (i2 + 2.0) - J * J;
  // B < 0 is not reached by any real F (it is (l1^2 - l2^2)^2/4); only round-off of a
  // nearly isotropic state gets here, and b = 0 is then the exact value.
  const double b = std::sqrt(std::max(B, 0.0));
  const double zmax = max_admissible_z(st.w);
  if (!(1.0 + a + b < zmax) || !(1.0 + a - b > 0.0)) return outside();
  std::size_t table = 0;
  if (b > 0.0) {
    // Nearest complex singularity of t -> V(1 + a + b cos t): the pole at z = 1/x0^2 and the
    // square-root branch point of V at z = 0 (V depends on x0 sqrt(z)).
    const double rho = std::min(std::acosh((zmax - 1.0 - a) / b), std::acosh((1.0 + a) / b));
    while (table + 1 < st.cos_t.size() && st.cos_t[table].size() * rho < 20.0) ++table;
  }
  const std::vector<double>& ct = st.cos_t[table];
  const std::vector<double>& s2 = st.sin2_t[table];
  AverageDerivatives g;
  for (std::size_t k = 0; k < ct.size(); ++k) {
    const std::array<double, 5> d = density_derivatives(st.w, 1.0 + a + b * ct[k]);
    g.g += d[0];
    g.ga += d[1];
    g.gaa += d[2];
    g.gb += d[2] * s2[k];
    g.gab += d[3] * s2[k];
    g.gbb += d[4] * s2[k] * s2[k];
  }
  const double n = static_cast<double>(ct.size());
  g.g /= n;
  g.ga /= n;
  g.gaa /= n;
  g.gb /= 2.0 * n;
  g.gab /= 2.0 * n;
  g.gbb /= 12.0 * n;
  return chain_to_invariants(g, steric_density(st.C, st.steric, J), i1, i2);
}

}  // namespace

Invariants invariants(const Eigen::Matrix2d& F) {
  return {F.determinant() - 1.0, F.squaredNorm() - 2.0};
}

Eigen::Matrix2d first_piola(const Eigen::Matrix2d& F, const InvariantDerivatives& d) {
  Eigen::Matrix2d cof;  // J F^{-T}
  cof << F(1, 1), -F(1, 0), -F(0, 1), F(0, 0);
  return d.d1 * cof + 2.0 * d.d2 * F;
}

IsotropicMembraneLaw make_membrane_law(const WlcDensity& w, const StericParameters& s,
                                       WlcExpansion expansion) {
  s.validate();
  auto st = std::make_shared<LawState>();
  st->w = w;
  st->w.expansion = expansion;
  st->steric = s;
  // C depends only on V'(1), identical for every expansion.
  st->C = steric_constant(w, s);
  IsotropicMembraneLaw law;
  if (expansion == WlcExpansion::full) {
    for (int K = 16; K <= 1024; K *= 2) {
      std::vector<double> c(K), s2(K);
      for (int k = 0; k < K; ++k) {
        const double t = (k + 0.5) * units::pi / K;
        c[k] = std::cos(t);
        s2[k] = std::sin(t) * std::sin(t);
      }
      st->cos_t.push_back(std::move(c));
      st->sin2_t.push_back(std::move(s2));
    }
    law.name = "full WLC, orientation-averaged";
    law.evaluate = [st](double i1, double i2) { return evaluate_full(*st, i1, i2); };
  } else {
    const int order = expansion_order(expansion);
    law.name = "Taylor order " + std::to_string(order) +
               (order > 2 ? ", orientation-averaged" : ", isotropic");
    law.evaluate = [st, order](double i1, double i2) {
      return evaluate_taylor(*st, order, i1, i2);
    };
  }
  return law;
}

IsotropicMembraneLaw make_membrane_law(const WlcParameters& p, const StericParameters& s,
                                       WlcExpansion expansion) {
  return make_membrane_law(make_wlc_density(p, expansion), s, expansion);
}

LinearModuli law_moduli(const IsotropicMembraneLaw& law) {
  const InvariantDerivatives d = law.evaluate(0.0, 0.0);
  LinearModuli m;
  m.mu_pN_per_um = d.d2 - 0.5 * d.d1;
  m.K_pN_per_um = 0.25 * (2 * d.d1 + 4 * d.d2 + 4 * d.d11 + 16 * d.d12 + 16 * d.d22);
  return m;
}

}  // namespace rbc
