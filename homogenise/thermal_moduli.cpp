// SPDX-License-Identifier: GPL-3.0-or-later
#include "homogenise/thermal_moduli.hpp"

#include <gsl/gsl_rng.h>
#include <omp.h>

#include <Eigen/SparseCholesky>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>

#include "core/units.hpp"
#include "core/validation.hpp"
#include "discrete/wlc.hpp"
#include "homogenise/disordered_network.hpp"
#include "homogenise/moduli.hpp"

namespace rbc {
namespace {

constexpr double kThermalInf = std::numeric_limits<double>::infinity();
constexpr long long kThermalMaxSweeps = 1000000000LL;

/// The three strain directions: the two pure shears and the equibiaxial stretch.
std::array<Eigen::Matrix2d, 3> thermal_directions() {
  Eigen::Matrix2d d1, d2;
  d1 << 1, 0, 0, -1;
  d2 << 0, 1, 1, 0;
  return {d1, d2, Eigen::Matrix2d::Identity()};
}

double contract(const Eigen::Matrix2d& a, const Eigen::Matrix2d& b) {
  return (a.array() * b.array()).sum();
}

/// splitmix64: independent-looking 64-bit seeds for the streams of one run from (seed, k).
unsigned long thermal_stream_seed(unsigned long seed, unsigned long k) {
  unsigned long long z = static_cast<unsigned long long>(seed) + 0x9E3779B97F4A7C15ULL * (k + 1);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return static_cast<unsigned long>(z ^ (z >> 31));
}

void validate_material(const ThermalCellMaterial& m) {
  if (m.law == CellLaw::harmonic)
    require_finite_in_range("harmonic spring constant", "pN/um", m.spring_pN_per_um, 0.0,
                            kUnbounded, Ends::open_open);
}

/// Energy of link e (pN um) for the vector d = F D_e + u_j - u_i.
inline double thermal_link_energy(const ThermalCellMaterial& m, const PeriodicEdge& e,
                                  const Eigen::Vector2d& d) {
  if (m.law == CellLaw::harmonic) return 0.5 * m.spring_pN_per_um * d.squaredNorm();
  const double lbar2 = e.lbar_um * e.lbar_um;
  const DensityValue v = evaluate(m.network.w, d.squaredNorm() / lbar2, 1);
  return 0.5 * units::sqrt3 * lbar2 * v.v;  // +infinity at or past Lmax
}

/// Energy of face f (pN um) for its deformed edge vectors; +infinity when inverted or collapsed.
inline double thermal_face_energy(const ThermalCellMaterial& m, const PeriodicFace& f,
                                  const Eigen::Vector2d& e1, const Eigen::Vector2d& e2) {
  if (m.law == CellLaw::harmonic) return 0.0;
  const double area = 0.5 * (e1.x() * e2.y() - e1.y() * e2.x());
  if (!(area > 0.0)) return kThermalInf;
  return f.abar_um2 *
         steric_density(m.network.C_pN_per_um, m.network.steric, area / f.abar_um2, 1).v;
}

/// A relaxed zero-temperature state at F: displacements, energy, stress, ln det H_uu.
struct RelaxedCell {
  Eigen::Matrix2Xd U;
  double energy_pNum = 0.0;
  Eigen::Matrix2d stress = Eigen::Matrix2d::Zero();
  double log_det = std::numeric_limits<double>::quiet_NaN();
};

RelaxedCell relaxed_cell(const PeriodicNetwork& net, const ThermalCellMaterial& m,
                         const Eigen::Matrix2d& F) {
  RelaxedCell r;
  const int N = net.vertex_count();
  if (m.law == CellLaw::network) {
    const CellRelaxResult rr = relax_patch(net, m.network, F);
    if (!rr.converged())
      throw std::runtime_error("thermal moduli: zero-temperature cell problem did not converge (" +
                               to_string(rr.status) + ", residual " +
                               format_scientific(rr.residual_pN) + " pN)");
    r.U = rr.U;
    if (N > 1) {
      const PatchHessian H = patch_hessian(net, m.network, F, r.U);
      Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(H.uu);
      if (ldlt.info() == Eigen::Success && (ldlt.vectorD().array() > 0.0).all())
        r.log_det = ldlt.vectorD().array().log().sum();
    } else {
      r.log_det = 0.0;
    }
  } else {
    // Quadratic energy: u solves k L u = -grad_u E(F, 0), L the graph Laplacian with vertex 0
    // pinned (x and y decouple; links to a vertex's own image move nothing).
    r.U = Eigen::Matrix2Xd::Zero(2, N);
    r.log_det = 0.0;  // F-independent: the quasi-harmonic shift is zero
    if (N > 1) {
      std::vector<Eigen::Triplet<double>> trip;
      Eigen::MatrixX2d rhs = Eigen::MatrixX2d::Zero(N - 1, 2);
      auto add = [&](int a, int b, double v) {
        if (a > 0 && b > 0) trip.emplace_back(a - 1, b - 1, v);
      };
      for (const PeriodicEdge& e : net.edges) {
        if (e.i == e.j) continue;
        add(e.i, e.i, 1.0);
        add(e.j, e.j, 1.0);
        add(e.i, e.j, -1.0);
        add(e.j, e.i, -1.0);
        const Eigen::Vector2d fd = F * e.ref;  // grad at u = 0: +k fd at j, -k fd at i
        if (e.j > 0) rhs.row(e.j - 1) -= fd.transpose();
        if (e.i > 0) rhs.row(e.i - 1) += fd.transpose();
      }
      Eigen::SparseMatrix<double> L(N - 1, N - 1);
      L.setFromTriplets(trip.begin(), trip.end());
      Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(L);
      if (ldlt.info() != Eigen::Success)
        throw std::runtime_error("thermal moduli: the harmonic network is not connected");
      const Eigen::MatrixX2d u = ldlt.solve(rhs);
      r.U.rightCols(N - 1) = u.transpose();
    }
  }
  r.energy_pNum = thermal_cell_energy(net, m, F, r.U, &r.stress);
  if (!(r.energy_pNum < kThermalInf))
    throw std::runtime_error("thermal moduli: relaxed cell outside the energy's domain");
  return r;
}

/// One Metropolis chain at fixed F: sequential single-node moves, one GSL mt19937 stream.
class ThermalChain {
 public:
  ThermalChain(const PeriodicNetwork& net, const ThermalCellMaterial& m, const Eigen::Matrix2d& F,
               Eigen::Matrix2Xd U0, double temperature_K, unsigned long seed)
      : net_(net),
        m_(m),
        F_(F),
        U_(std::move(U0)),
        beta_(1.0 / units::thermal_energy_pNum(temperature_K)),
        rng_(gsl_rng_alloc(gsl_rng_mt19937), &gsl_rng_free) {
    if (!rng_) throw std::bad_alloc();
    gsl_rng_set(rng_.get(), seed);
    const int N = net.vertex_count();
    edge_at_.assign(N, {});
    face_at_.assign(N, {});
    fd_.resize(net.edges.size());
    for (size_t e = 0; e < net.edges.size(); ++e) {
      const PeriodicEdge& ed = net.edges[e];
      fd_[e] = F * ed.ref;
      if (ed.i == ed.j) continue;  // a link to the node's own image: moves never change it
      edge_at_[ed.i].push_back(static_cast<int>(e));
      edge_at_[ed.j].push_back(static_cast<int>(e));
    }
    fe1_.resize(net.faces.size());
    fe2_.resize(net.faces.size());
    if (m.law == CellLaw::network)
      for (size_t f = 0; f < net.faces.size(); ++f) {
        const PeriodicFace& fa = net.faces[f];
        fe1_[f] = F * fa.e1;
        fe2_[f] = F * fa.e2;
        for (int k = 0; k < 3; ++k) {
          auto& list = face_at_[fa.v[k]];
          if (std::find(list.begin(), list.end(), static_cast<int>(f)) == list.end())
            list.push_back(static_cast<int>(f));
        }
      }
  }

  /// Energy of the elements at node v (pN um) for the current U.
  double local_energy(int v) const {
    double E = 0.0;
    for (int e : edge_at_[v]) {
      const PeriodicEdge& ed = net_.edges[e];
      E += thermal_link_energy(m_, ed, fd_[e] + U_.col(ed.j) - U_.col(ed.i));
    }
    for (int f : face_at_[v]) {
      const PeriodicFace& fa = net_.faces[f];
      const Eigen::Vector2d u0 = U_.col(fa.v[0]);
      E += thermal_face_energy(m_, fa, fe1_[f] + U_.col(fa.v[1]) - u0,
                               fe2_[f] + U_.col(fa.v[2]) - u0);
    }
    return E;
  }

  /// One sweep (every node offered one move, in order) with trial half-width step_um; returns
  /// the accepted fraction. Three uniforms per move whatever happens (common random numbers).
  double sweep(double step_um) {
    const int N = net_.vertex_count();
    long long accepted = 0;
    for (int v = 0; v < N; ++v) {
      const double r1 = gsl_rng_uniform(rng_.get());
      const double r2 = gsl_rng_uniform(rng_.get());
      const double r3 = gsl_rng_uniform(rng_.get());
      const Eigen::Vector2d old = U_.col(v);
      const double e_old = local_energy(v);
      U_.col(v) = old + step_um * Eigen::Vector2d(2.0 * r1 - 1.0, 2.0 * r2 - 1.0);
      const double e_new = local_energy(v);
      // Metropolis: accept with probability min(1, exp(-beta dE)); infeasible: reject.
      if (e_new < kThermalInf && r3 < std::exp(-beta_ * (e_new - e_old)))
        ++accepted;
      else
        U_.col(v) = old;
    }
    return N > 0 ? double(accepted) / N : 0.0;
  }

  /// Energy (pN um) and stress (pN/um) of the current state.
  double measure(Eigen::Matrix2d& stress) const {
    return thermal_cell_energy(net_, m_, F_, U_, &stress);
  }
  const Eigen::Matrix2Xd& U() const { return U_; }

 private:
  const PeriodicNetwork& net_;
  const ThermalCellMaterial& m_;
  Eigen::Matrix2d F_;
  Eigen::Matrix2Xd U_;
  double beta_;
  std::unique_ptr<gsl_rng, void (*)(gsl_rng*)> rng_;
  std::vector<std::vector<int>> edge_at_, face_at_;
  std::vector<Eigen::Vector2d> fd_, fe1_, fe2_;
};

/// Mean and batch-means standard error of a series (B batches of equal size; the leftover
/// sweeps at the start are left out of both).
ValueError batch_means(const std::vector<double>& x, int batches) {
  const long long n = static_cast<long long>(x.size());
  const long long size = n / batches;
  const long long first = n - size * batches;
  std::vector<double> means(batches, 0.0);
  double total = 0.0;
  for (int b = 0; b < batches; ++b) {
    double s = 0.0;
    for (long long k = first + b * size; k < first + (b + 1) * size; ++k) s += x[k];
    means[b] = s / size;
    total += s;
  }
  ValueError r;
  r.value = total / double(size * batches);
  double var = 0.0;
  for (double mb : means) var += (mb - r.value) * (mb - r.value);
  var /= (batches - 1);
  r.error = std::sqrt(var / batches);
  return r;
}

}  // namespace

void ThermalModuliOptions::validate() const {
  require_finite_in_range("sampling temperature", "K", temperature_K, 0.0, kMaxTemperature_K,
                          Ends::closed_closed);
  require_integer_in_range("thermal moduli batches", batches, 4, 1000);
  require_integer_in_range("thermal moduli sweeps", sweeps, batches, kThermalMaxSweeps);
  require_integer_in_range("thermal moduli warm-up sweeps", warmup_sweeps, 0, kThermalMaxSweeps);
  require_finite_in_range("thermal moduli strain", "", strain, 0.0, 0.05);
  require_integer_in_range("thermal moduli progress blocks", blocks, 1, 1000);
  require_finite_in_range("thermal moduli target acceptance", "", target_acceptance, 0.0, 1.0,
                          Ends::open_open);
  require_finite_in_range("thermal moduli initial step", "um", initial_step_um, 0.0, 1.0,
                          Ends::closed_closed);
  require_integer_in_range("thermal moduli threads", threads, 0, 1024);
}

double thermal_cell_energy(const PeriodicNetwork& net, const ThermalCellMaterial& m,
                           const Eigen::Matrix2d& F, const Eigen::Matrix2Xd& U,
                           Eigen::Matrix2d* stress) {
  const double area = net.reference_area_um2();
  if (m.law == CellLaw::network) {
    Eigen::Matrix2d gF;
    const double E = patch_energy(net, m.network, F, U, nullptr, stress ? &gF : nullptr);
    if (stress && E < kThermalInf) *stress = gF / area;
    return E;
  }
  double E = 0.0;
  Eigen::Matrix2d gF = Eigen::Matrix2d::Zero();
  for (const PeriodicEdge& e : net.edges) {
    const Eigen::Vector2d d = F * e.ref + U.col(e.j) - U.col(e.i);
    E += 0.5 * m.spring_pN_per_um * d.squaredNorm();
    gF += m.spring_pN_per_um * d * e.ref.transpose();
  }
  if (stress) *stress = gF / area;
  return E;
}

ThermalChainSeries sample_cell(const PeriodicNetwork& net, const ThermalCellMaterial& material,
                               const Eigen::Matrix2d& F, const Eigen::Matrix2Xd& U0,
                               double temperature_K, double step_um, long long sweeps,
                               unsigned long seed) {
  validate_material(material);
  require_finite_in_range("sampling temperature", "K", temperature_K, 0.0, kMaxTemperature_K);
  require_finite_in_range("thermal moduli step", "um", step_um, 0.0, 1.0);
  ThermalChain chain(net, material, F, U0, temperature_K, seed);
  ThermalChainSeries s;
  double acc = 0.0;
  for (long long k = 0; k < sweeps; ++k) {
    acc += chain.sweep(step_um);
    Eigen::Matrix2d P;
    s.energy_pNum.push_back(chain.measure(P));
    s.stress.emplace_back(P(0, 0), P(0, 1), P(1, 0), P(1, 1));
  }
  s.acceptance = sweeps > 0 ? acc / sweeps : 0.0;
  s.U = chain.U();
  return s;
}

ThermalModuliResult thermal_moduli(const PeriodicNetwork& net, const ThermalCellMaterial& m,
                                   const ThermalModuliOptions& o, const ProgressSink& progress) {
  o.validate();
  validate_material(m);
  const int N = net.vertex_count();
  if (N < 2) throw std::invalid_argument("thermal moduli: the cell needs at least 2 vertices");
  const double area = net.reference_area_um2();
  const double eps = o.strain;
  const auto dirs = thermal_directions();
  ThermalModuliResult r;
  r.temperature_K = o.temperature_K;
  r.vertices = N;
  r.area_um2 = area;
  r.strain = eps;
  r.sweeps = o.sweeps;
  r.warmup_sweeps = o.warmup_sweeps;
  r.batches = o.batches;
  r.seed = o.seed;

  // Zero temperature: relaxed states at F = I and I +- eps D, their central differences, the
  // Gamma-limit tangent and the quasi-harmonic O(T) shift.
  const RelaxedCell rest = relaxed_cell(net, m, Eigen::Matrix2d::Identity());
  std::array<std::array<RelaxedCell, 2>, 3> strained;
  for (int d = 0; d < 3; ++d)
    for (int s = 0; s < 2; ++s)
      strained[d][s] =
          relaxed_cell(net, m, Eigen::Matrix2d::Identity() + (s == 0 ? eps : -eps) * dirs[d]);
  std::array<double, 3> t0{}, qh{};
  for (int d = 0; d < 3; ++d) {
    t0[d] = contract(dirs[d], strained[d][0].stress - strained[d][1].stress) / (2 * eps);
    qh[d] = (strained[d][0].log_det - 2 * rest.log_det + strained[d][1].log_det) / (eps * eps);
  }
  r.zero_temperature_cd.mu_pN_per_um = (t0[0] + t0[1]) / 8;
  r.zero_temperature_cd.K_pN_per_um = t0[2] / 4;
  // The tension as the chains measure it: the mean over the +-eps cells of the I direction
  // (F = I to O(eps^2)).
  r.zero_temperature_tension_pN_per_um =
      0.25 * (strained[2][0].stress.trace() + strained[2][1].stress.trace());
  if (m.law == CellLaw::network) {
    r.gamma_limit = moduli_from_tangent(
        homogenise_patch(net, m.network, Eigen::Matrix2d::Identity()).relaxed_tangent);
  } else {
    r.gamma_limit = r.zero_temperature_cd;  // quadratic energy: the difference is exact
  }
  const double kT = units::thermal_energy_pNum(o.temperature_K);
  r.quasi_harmonic = r.zero_temperature_cd;
  r.quasi_harmonic.mu_pN_per_um += kT / (2 * area) * (qh[0] + qh[1]) / 8;
  r.quasi_harmonic.K_pN_per_um += kT / (2 * area) * qh[2] / 4;

  if (o.temperature_K == 0.0) {
    r.sweeps = r.warmup_sweeps = 0;  // nothing sampled
    r.mu = {r.zero_temperature_cd.mu_pN_per_um, 0.0};
    r.K = {r.zero_temperature_cd.K_pN_per_um, 0.0};
    r.tangent_d1 = {t0[0], 0.0};
    r.tangent_d2 = {t0[1], 0.0};
    r.tangent_i = {t0[2], 0.0};
    r.tension_pN_per_um = {r.zero_temperature_tension_pN_per_um, 0.0};
    r.equipartition_ratio = {std::numeric_limits<double>::quiet_NaN(), 0.0};
    return r;
  }

  // Warm-up at F = I: adapt the trial half-width towards the target acceptance, then freeze it.
  double min_lbar = kThermalInf;
  for (const PeriodicEdge& e : net.edges) min_lbar = std::min(min_lbar, e.lbar_um);
  double step = o.initial_step_um > 0 ? o.initial_step_um : 0.01 * min_lbar;
  {
    ThermalChain warm(net, m, Eigen::Matrix2d::Identity(), rest.U, o.temperature_K,
                      thermal_stream_seed(o.seed, 3));
    const double gain = 0.5 * N / (N + 200.0);
    for (long long k = 0; k < o.warmup_sweeps; ++k) {
      if (k % 1000 == 0) throw_if_cancelled(o.cancel);
      const double a = warm.sweep(step);
      step = std::min(std::exp(std::log(step) + gain * (a - o.target_acceptance)), 1.0);
    }
  }
  r.step_um = step;
  report(progress, "thermal moduli: T = " + format_number(o.temperature_K) + " K, " +
                       std::to_string(N) + " nodes, step " + format_number(step * 1e3) +
                       " nm after " + std::to_string(o.warmup_sweeps) + " warm-up sweeps");

  // Six chains: direction d = c / 2, sign + (c even) or - (c odd); +eps and -eps share a seed.
  std::vector<std::unique_ptr<ThermalChain>> chains;
  for (int c = 0; c < 6; ++c) {
    const int d = c / 2, s = c % 2;
    chains.push_back(std::make_unique<ThermalChain>(
        net, m, Eigen::Matrix2d::Identity() + (s == 0 ? eps : -eps) * dirs[d], strained[d][s].U,
        o.temperature_K, thermal_stream_seed(o.seed, d)));
  }
  std::array<std::vector<double>, 6> proj, excess;
  std::array<double, 6> accepted{};
  const long long total = o.warmup_sweeps + o.sweeps;
  const int threads = o.threads > 0 ? std::min(o.threads, 6) : std::min(omp_get_max_threads(), 6);
  long long done = 0;
  for (int b = 0; b < o.blocks; ++b) {
    throw_if_cancelled(o.cancel);
    const long long end = total * (b + 1) / o.blocks;
#pragma omp parallel for schedule(static, 1) num_threads(threads)
    for (int c = 0; c < 6; ++c) {
      const int d = c / 2, s = c % 2;
      for (long long k = done; k < end; ++k) {
        const double a = chains[c]->sweep(step);
        if (k < o.warmup_sweeps) continue;  // burn-in from the relaxed state
        accepted[c] += a;
        Eigen::Matrix2d P;
        const double E = chains[c]->measure(P);
        proj[c].push_back(contract(dirs[d], P));
        excess[c].push_back(E - strained[d][s].energy_pNum);
      }
    }
    done = end;
    if (done > o.warmup_sweeps) {
      const long long n = static_cast<long long>(proj[0].size());
      double mu = 0.0, K = 0.0;
      for (long long k = 0; k < n; ++k) {
        mu += (proj[0][k] - proj[1][k] + proj[2][k] - proj[3][k]) / (2 * eps) / 8;
        K += (proj[4][k] - proj[5][k]) / (2 * eps) / 4;
      }
      report(progress, "thermal moduli: block " + std::to_string(b + 1) + "/" +
                           std::to_string(o.blocks) + ", " + std::to_string(n) +
                           " production sweeps: mu = " + format_number(mu / n) +
                           " pN/um, K = " + format_number(K / n) + " pN/um (running means)");
    } else {
      report(progress, "thermal moduli: block " + std::to_string(b + 1) + "/" +
                           std::to_string(o.blocks) + ", burn-in sweep " + std::to_string(done));
    }
  }

  const long long n = o.sweeps;
  std::vector<double> mu_k(n), K_k(n), t1(n), t2(n), ti(n), tension(n), equi(n);
  const double dofs = 2.0 * (N - 1);
  for (long long k = 0; k < n; ++k) {
    t1[k] = (proj[0][k] - proj[1][k]) / (2 * eps);
    t2[k] = (proj[2][k] - proj[3][k]) / (2 * eps);
    ti[k] = (proj[4][k] - proj[5][k]) / (2 * eps);
    mu_k[k] = (t1[k] + t2[k]) / 8;
    K_k[k] = ti[k] / 4;
    tension[k] = (proj[4][k] + proj[5][k]) / 4;  // (tr P(+) + tr P(-)) / 2, halved
    double ex = 0.0;
    for (int c = 0; c < 6; ++c) ex += excess[c][k];
    equi[k] = ex / 6 / dofs / (0.5 * kT);
  }
  r.mu = batch_means(mu_k, o.batches);
  r.K = batch_means(K_k, o.batches);
  r.tangent_d1 = batch_means(t1, o.batches);
  r.tangent_d2 = batch_means(t2, o.batches);
  r.tangent_i = batch_means(ti, o.batches);
  r.tension_pN_per_um = batch_means(tension, o.batches);
  r.equipartition_ratio = batch_means(equi, o.batches);
  double acc = 0.0;
  for (double a : accepted) acc += a;
  r.acceptance = acc / (6.0 * n);
  return r;
}

nlohmann::json to_json(const ThermalModuliResult& r) {
  auto shift = [](double v, double ref) { return v / ref - 1.0; };
  return {{"sampling_temperature_K", r.temperature_K},
          {"vertices", r.vertices},
          {"cell_area_um2", r.area_um2},
          {"strain", r.strain},
          {"mu_pN_per_um", r.mu.value},
          {"mu_error_pN_per_um", r.mu.error},
          {"K_pN_per_um", r.K.value},
          {"K_error_pN_per_um", r.K.error},
          {"mu_gamma_pN_per_um", r.gamma_limit.mu_pN_per_um},
          {"K_gamma_pN_per_um", r.gamma_limit.K_pN_per_um},
          {"mu_relative_shift", shift(r.mu.value, r.gamma_limit.mu_pN_per_um)},
          {"mu_relative_shift_error", r.mu.error / r.gamma_limit.mu_pN_per_um},
          {"K_relative_shift", shift(r.K.value, r.gamma_limit.K_pN_per_um)},
          {"K_relative_shift_error", r.K.error / r.gamma_limit.K_pN_per_um},
          {"mu_zero_temperature_cd_pN_per_um", r.zero_temperature_cd.mu_pN_per_um},
          {"K_zero_temperature_cd_pN_per_um", r.zero_temperature_cd.K_pN_per_um},
          {"mu_quasi_harmonic_pN_per_um", r.quasi_harmonic.mu_pN_per_um},
          {"K_quasi_harmonic_pN_per_um", r.quasi_harmonic.K_pN_per_um},
          {"tangent_d1_pN_per_um", r.tangent_d1.value},
          {"tangent_d1_error_pN_per_um", r.tangent_d1.error},
          {"tangent_d2_pN_per_um", r.tangent_d2.value},
          {"tangent_d2_error_pN_per_um", r.tangent_d2.error},
          {"tangent_i_pN_per_um", r.tangent_i.value},
          {"tangent_i_error_pN_per_um", r.tangent_i.error},
          {"tension_pN_per_um", r.tension_pN_per_um.value},
          {"tension_error_pN_per_um", r.tension_pN_per_um.error},
          {"tension_zero_temperature_pN_per_um", r.zero_temperature_tension_pN_per_um},
          {"equipartition_ratio", r.equipartition_ratio.value},
          {"equipartition_ratio_error", r.equipartition_ratio.error},
          {"acceptance", r.acceptance},
          {"step_um", r.step_um},
          {"sweeps", r.sweeps},
          {"warmup_sweeps", r.warmup_sweeps},
          {"batches", r.batches},
          {"seed", r.seed}};
}

void ThermalStudyOptions::validate() const {
  if (network == ModuliNetwork::hexagonal) {
    if (cells != 0)
      require_integer_in_range("hexagonal patch cells", cells, 3, kMaxHexagonalPatchCells);
  } else if (cells != 0) {
    require_integer_in_range("disordered network cells", cells, 4, 200);
  }
  require_finite_in_range("disorder X", "", disorder, 0.0, 1.0, Ends::closed_closed);
  sampling.validate();
}

nlohmann::json thermal_moduli_study(const WlcParameters& wlc, const StericParameters& steric,
                                    const ThermalStudyOptions& o, const ProgressSink& progress) {
  o.validate();
  ThermalCellMaterial m;
  m.network = make_network_material(wlc, steric);
  PeriodicNetwork net;
  int cells = o.cells;
  if (o.network == ModuliNetwork::hexagonal) {
    cells = cells > 0 ? cells : 10;
    net = make_hexagonal_patch(cells, wlc.lbar_um);
  } else {
    DisorderOptions d;
    d.cells = cells > 0 ? cells : 12;
    d.disorder = o.disorder;
    d.spacing_um = wlc.lbar_um;
    d.validate();
    cells = d.cells;
    net = make_disordered_network(d, 1);
  }
  const ThermalModuliResult r = thermal_moduli(net, m, o.sampling, progress);
  const LinearModuli closed = closed_form_moduli(m.network.w, steric);
  nlohmann::json j = {{"network", to_string(o.network)},
                      {"cells", cells},
                      {"wlc_temperature_K", wlc.temperature_K},
                      {"mu_closed_pN_per_um", closed.mu_pN_per_um},
                      {"K_closed_pN_per_um", closed.K_pN_per_um}};
  if (o.network == ModuliNetwork::disordered) {
    j["disorder"] = o.disorder;
    j["network_seed"] = 1;
  }
  j.update(to_json(r));
  return j;
}

}  // namespace rbc
