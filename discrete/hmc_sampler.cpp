// SPDX-License-Identifier: GPL-3.0-or-later
#include "discrete/hmc_sampler.hpp"

#include <gsl/gsl_randist.h>
#include <omp.h>

#include <Eigen/Cholesky>
#include <cmath>
#include <cstring>
#include <stdexcept>

#include "core/geometry.hpp"
#include "core/sparse_cholesky.hpp"
#include "core/units.hpp"
#include "discrete/network_energy.hpp"
#include "discrete/network_hessian.hpp"

namespace rbc {

namespace {
constexpr double kRotationMassFactor = 1e4;  ///< a rotation's mass over the translations'

/// Area (um^2) and enclosed volume (um^3) of the closed mesh at x, with their gradients (the
/// triangle and tetrahedron formulas of core/geometry.hpp, summed face by face in a fixed order).
void area_volume_gradients(const Topology& t, const Positions& x, double& area, double& volume,
                           Positions& ga, Positions& gv) {
  const int n = t.num_vertices;
  ga = Positions::Zero(3, n);
  gv = Positions::Zero(3, n);
  area = 0;
  volume = 0;
  for (int f = 0; f < t.num_faces(); ++f) {
    Eigen::Matrix3d g;
    const Vec3 a = x.col(t.faces(0, f)), b = x.col(t.faces(1, f)), c = x.col(t.faces(2, f));
    area += triangle_area(a, b, c, &g);
    for (int k = 0; k < 3; ++k) ga.col(t.faces(k, f)) += g.col(k);
    volume += tetra_volume(a, b, c, &g);
    for (int k = 0; k < 3; ++k) gv.col(t.faces(k, f)) += g.col(k);
  }
}

/// The Euclidean metric as a MassMatrix (M = I): the start's projection onto the area and volume
/// moves along J' itself. Along M^-1 J' the penalty columns of M (stiffness s k_A) make the
/// Woodbury solve cancel to a few digits, and Newton's method did not converge from a draw.
class UnitMass final : public MassMatrix {
 public:
  explicit UnitMass(Eigen::Index size) : size_(size) {}
  Eigen::VectorXd draw(gsl_rng* rng) const override {
    Eigen::VectorXd z(size_);
    for (Eigen::Index i = 0; i < size_; ++i) z(i) = gsl_ran_gaussian_ziggurat(rng, 1.0);
    return z;
  }
  Eigen::VectorXd inverse_times(const Eigen::VectorXd& p) const override { return p; }
  int solves_per_inverse() const override { return 0; }
  int solves_per_draw() const override { return 0; }

 private:
  Eigen::Index size_;
};

/// The constraints A(x) = a0 (um^2) and V(x) = v0 (um^3) (the network's A0 and V0 for
/// HmcAreaVolume::exact), to 1e-10 of a0 and v0. Their Hessian-vector products (for the Fixman
/// term's gradient only) are central differences of the exact gradients with a largest displacement
/// of 1e-6 um: accurate to about 1e-9 relative, and the transition stays exact with any
/// deterministic force (the acceptance uses the exact Fixman term), so the cost of per-face area
/// and volume Hessians is not paid.
HmcConstraints area_volume_constraints(const Network& net, double a0, double v0) {
  HmcConstraints c;
  const Topology* topo = &net.topo;
  c.evaluate = [topo, a0, v0](const Eigen::VectorXd& q, Eigen::VectorXd& value,
                              Eigen::MatrixXd& jt) {
    const int n = topo->num_vertices;
    double area = 0, volume = 0;
    Positions ga, gv;
    area_volume_gradients(*topo, Eigen::Map<const Positions>(q.data(), 3, n), area, volume, ga, gv);
    value.resize(2);
    value << area - a0, volume - v0;
    jt.resize(q.size(), 2);
    jt.col(0) = flat(ga);
    jt.col(1) = flat(gv);
  };
  c.hessian_times = [topo](const Eigen::VectorXd& q, int a, const Eigen::VectorXd& w) {
    const int n = topo->num_vertices;
    const double largest = w.cwiseAbs().maxCoeff();
    if (!(largest > 0)) return Eigen::VectorXd(Eigen::VectorXd::Zero(q.size()));
    const double eps = 1e-6 / largest;
    double area = 0, volume = 0;
    Positions gap, gvp, gam, gvm;
    const Eigen::VectorXd qp = q + eps * w, qm = q - eps * w;
    area_volume_gradients(*topo, Eigen::Map<const Positions>(qp.data(), 3, n), area, volume, gap,
                          gvp);
    area_volume_gradients(*topo, Eigen::Map<const Positions>(qm.data(), 3, n), area, volume, gam,
                          gvm);
    return Eigen::VectorXd(a == 0 ? (flat(gap) - flat(gam)) / (2 * eps)
                                  : (flat(gvp) - flat(gvm)) / (2 * eps));
  };
  c.tolerance.resize(2);
  c.tolerance << 1e-10 * a0, 1e-10 * v0;
  c.reverse_tolerance = 1e-7;  // um
  return c;
}
}  // namespace

std::vector<int> rigid_rotation_axes(const LoadState& load) {
  if (load.force_pN == 0.0) return {0, 1, 2};
  return {0};
}

/// M = beta (K0 + U C U') with its factor (see the header).
NetworkMassMatrix::NetworkMassMatrix(const Network& net, const LoadState& load, const Positions& x,
                                     double beta, const HmcOptions& options)
    : beta_(beta), factor_([] {
        SparseCholeskyOptions o;
        o.solve_precision = SolvePrecision::double_precision;
        o.blas_threads = 1;
        return o;
      }()) {
  const Topology& t = net.topo;
  const int n = t.num_vertices;
  Positions ga, gv;
  double area = 0, volume = 0;
  area_volume_gradients(t, x, area, volume, ga, gv);
  const double s = load.stiffness_scale;
  const double ka = s * net.constraints.area_stiffness_pN_per_um3;
  const double kv = s * net.constraints.volume_stiffness_pN_per_um5;
  ConstraintCurvature cc;
  cc.tension_pN_per_um = load.multipliers.area_pN_per_um + ka * (area - net.area0_um2);
  cc.pressure_pN_per_um2 = load.multipliers.volume_pN_per_um2 + kv * (volume - net.volume0_um3);

  NetworkHessianOptions ho;
  ho.shift_fraction = 0.0;
  NetworkHessian hessian(net, ho);
  auto with_shift = [&](const Eigen::SparseMatrix<double>& h) {
    k0_ = h;
    const double mean_diagonal = k0_.diagonal().sum() / double(3 * n);
    info_.shift_pN_per_um = options.mass_shift_fraction * mean_diagonal;
    info_.rigid_mass_pN_per_um = mean_diagonal;
    for (int i = 0; i < 3 * n; ++i) k0_.coeffRef(i, i) += info_.shift_pN_per_um;
    return factor_.factorize(k0_);
  };
  info_.exact = !options.projected_mass && with_shift(hessian.assemble_exact(x, cc));
  if (!info_.exact && !with_shift(hessian.assemble(x, cc, true)))
    throw std::runtime_error("HMC mass matrix: the projected network Hessian did not factorise");
  info_.factor_nonzeros = factor_.factor_nonzeros();

  // Low-rank part: columns of U and the diagonal of C (pN/um): dA and dV (penalties only: exact
  // constraints take the momentum out of those directions), the three translations and the
  // rotations that leave F unchanged (see rigid_rotation_axes()).
  const std::vector<int> axes = rigid_rotation_axes(load);
  const int penalties = options.area_volume == HmcAreaVolume::penalty ? 2 : 0;
  const int low_rank = penalties + 3 + static_cast<int>(axes.size());
  u_.resize(3 * n, low_rank);
  c_.resize(low_rank);
  if (penalties) {
    u_.col(0) = flat(ga);
    u_.col(1) = flat(gv);
    c_(0) = ka;
    c_(1) = kv;
  }
  const Eigen::Vector3d centre = x.rowwise().mean();
  for (int d = 0; d < 3; ++d) {
    Positions t3 = Positions::Zero(3, n);
    t3.row(d).setConstant(1.0 / std::sqrt(double(n)));
    u_.col(penalties + d) = flat(t3);
    c_(penalties + d) = info_.rigid_mass_pN_per_um;
  }
  // The rotations, heavier still: the mass matrix is fixed in the laboratory frame, so a cell
  // that turns away from the reference orientation meets a mass matrix whose stiff directions
  // (the area and volume penalties above all) no longer line up with its own, and the tolerated
  // step shrinks as it turns (measured at N = 492, 88 pN: the acceptance fell from 0.64 to 0.08
  // over 1,100 trajectories while the cell turned by 0.26 degrees about the axis; at 0 pN, with
  // only the axis rotation heavy, to 0.002 while the cell tilted). 1e4 times the mass makes each
  // trajectory turn it 100 times less; F does not depend on these angles, so the law is
  // unchanged.
  for (std::size_t k = 0; k < axes.size(); ++k) {
    Positions r = Positions::Zero(3, n);
    const Eigen::Vector3d e = Eigen::Vector3d::Unit(axes[k]);
    for (int i = 0; i < n; ++i) r.col(i) = e.cross(Eigen::Vector3d(x.col(i) - centre));
    r /= r.norm();
    u_.col(penalties + 3 + static_cast<int>(k)) = flat(r);
    c_(penalties + 3 + static_cast<int>(k)) = kRotationMassFactor * info_.rigid_mass_pN_per_um;
  }
  w_ = factor_.solve(Eigen::MatrixXd(u_));
  Eigen::MatrixXd cap = u_.transpose() * w_;
  for (Eigen::Index k = 0; k < c_.size(); ++k) cap(k, k) += 1.0 / c_(k);
  capacitance_.compute(cap);
  if (capacitance_.info() != Eigen::Success)
    throw std::runtime_error("HMC mass matrix: the Woodbury capacitance is singular");
}

Eigen::VectorXd NetworkMassMatrix::draw(gsl_rng* rng) const {
  const Eigen::Index m = k0_.rows();
  Eigen::VectorXd z(m);
  for (Eigen::Index i = 0; i < m; ++i) z(i) = gsl_ran_gaussian_ziggurat(rng, 1.0);
  Eigen::VectorXd z2(c_.size());
  for (Eigen::Index k = 0; k < c_.size(); ++k) z2(k) = gsl_ran_gaussian_ziggurat(rng, 1.0);
  const Eigen::VectorXd w = factor_.solve_factor_transpose(z);  // ~ N(0, K0^-1)
  Eigen::VectorXd p = k0_.selfadjointView<Eigen::Lower>() * w;  // ~ N(0, K0)
  p.noalias() += u_ * (c_.cwiseSqrt().cwiseProduct(z2));
  return std::sqrt(beta_) * p;
}

Eigen::VectorXd NetworkMassMatrix::inverse_times(const Eigen::VectorXd& p) const {
  Eigen::VectorXd y = factor_.solve(p);
  y.noalias() -= w_ * capacitance_.solve(u_.transpose() * y);
  return y / beta_;
}

HmcSampler::HmcSampler(const Network& net, const LoadState& load, const Positions& start,
                       const McOptions& options)
    : HmcSampler(net, load, start, start, options) {}

HmcSampler::HmcSampler(const Network& net, const LoadState& load, const Positions& start,
                       const Positions& mass_reference, const McOptions& options)
    : net_(net), load_(load), opt_(options), rng_(gsl_rng_alloc(gsl_rng_mt19937)) {
  if (opt_.algorithm != McAlgorithm::hmc)
    throw std::invalid_argument("HmcSampler needs McOptions::algorithm = hmc");
  opt_.validate();
  const int n = net.topo.num_vertices;
  if (start.cols() != n || mass_reference.cols() != n)
    throw std::invalid_argument("start positions have " + std::to_string(start.cols()) +
                                " vertices, the network " + std::to_string(n));
  beta_ = 1.0 / units::thermal_energy_pNum(opt_.temperature_K);
  if (!std::isfinite(network_energy(net_, mass_reference, load_)))
    throw std::invalid_argument(
        "HMC mass reference is infeasible (a link at Lmax or a collapsed face)");
  reference_ = mass_reference;
  mass_ = std::make_unique<NetworkMassMatrix>(net_, load_, reference_, beta_, opt_.hmc);
  mass_info_ = mass_->info();
  // Exact constraints: F without the penalties and the multiplier terms, which are constant
  // (zero) on the manifold A = A0, V = V0.
  potential_load_ = load_;
  if (opt_.hmc.area_volume == HmcAreaVolume::exact) {
    potential_load_.multipliers = ConstraintMultipliers{};
    potential_load_.stiffness_scale = 0.0;
    constraints_ = std::make_unique<HmcConstraints>(
        area_volume_constraints(net_, net_.area0_um2, net_.volume0_um3));
  }
  potential_ = [this](const Eigen::VectorXd& q, Eigen::VectorXd& grad) {
    const Eigen::Map<const Positions> xq(q.data(), 3, net_.topo.num_vertices);
    Positions g(3, net_.topo.num_vertices);
    const double f = network_energy(net_, Positions(xq), potential_load_, &g);
    grad = beta_ * flat(g);
    return beta_ * f;
  };
  gsl_rng_set(rng_.get(), opt_.seed);
  step_ = opt_.hmc.step;
  threads_.threads = threads_.requested = std::max(1, omp_get_max_threads());
  threads_.reason = std::to_string(threads_.threads) +
                    ": one chain, energy and gradient on the OpenMP threads (deterministic sums)";
  start_near(start);
}

HmcSampler::~HmcSampler() = default;

void HmcSampler::start_near(const Positions& centre) {
  // The chain starts at a draw of the Gaussian (Laplace) approximation of the target about
  // `centre`, x0 = centre + M^-1 p with p ~ N(0, M), of covariance M^-1 = kB T K^-1, not at
  // `centre` itself. From a minimum every normal mode starts in phase (at rest in position), and
  // the leapfrog's energy error, which for a harmonic mode of frequency w is
  // h^2 w^4 (x_end^2 - x_start^2) / 8 (the step conserves H minus h^2 w^4 x^2 / 8), adds up
  // coherently over the d degrees of freedom: about h^2 d / 8 at w = 1 (29 at h = 0.1 and
  // N = 7,842; 29.4 measured). That rejects the first trajectories and drives the adapted step
  // tenfold down at N = 27,000. From a typical state the terms cancel to about h^2 sqrt(d).
  // The draw is then moved back onto the centre's area and volume: with exact constraints onto
  // A0 and V0 along M^-1 J', which makes it a draw of the Gaussian restricted to the tangent
  // space; with penalties along J' (see UnitMass for why), a second-order correction, since M
  // holds the penalties' stiffness already. A Gaussian draw roughens the surface, which raises the
  // area at second order, dA = grad A' d + d' (grad^2 A) d / 2, and the penalties turn that into
  // thousands of kB T (at N = 250, 88 pN, scale 25: 9,500 kB T above the minimum, against the 376
  // of the Gaussian approximation; 370 once projected). A draw outside the model's domain, or off
  // the projection's reach, is halved towards the centre, up to kStartHalvings times; then the
  // chain starts at the centre.
  constexpr int kStartHalvings = 30;
  const int n = net_.topo.num_vertices;
  const Eigen::VectorXd c = flat(centre);
  const NetworkGeometry geo = network_geometry(centre, net_.topo);
  const HmcConstraints onto =
      area_volume_constraints(net_, constraints_ ? net_.area0_um2 : geo.area_um2,
                              constraints_ ? net_.volume0_um3 : geo.volume_um3);
  Eigen::VectorXd delta = mass_->inverse_times(mass_->draw(rng_.get()));
  solves_ += mass_->solves_per_draw() + mass_->solves_per_inverse();
  for (int k = 0; k < kStartHalvings; ++k, delta *= 0.5) {
    Eigen::VectorXd q;
    try {
      q = constraints_ ? hmc_project_onto_constraints(onto, *mass_, c + delta)
                       : hmc_project_onto_constraints(onto, UnitMass(c.size()), c + delta);
    } catch (const std::runtime_error&) {
      continue;  // Newton did not reach the area and volume from there
    }
    const Positions x = Eigen::Map<const Positions>(q.data(), 3, n);
    if (!std::isfinite(network_energy(net_, x, potential_load_))) continue;
    set_state(x);
    return;
  }
  set_state(centre);
}

void HmcSampler::set_state(const Positions& x) {
  if (constraints_) {
    // Onto A = A0, V = V0 along M^-1 J' (a state already there, as a checkpoint's, is kept).
    Eigen::VectorXd on;
    try {
      on = hmc_project_onto_constraints(*constraints_, *mass_, flat(x));
    } catch (const std::runtime_error& e) {
      throw std::invalid_argument(std::string("Monte Carlo start: ") + e.what());
    }
    state_ = hmc_constrained_state(potential_, *constraints_, *mass_, on);
    x_ = Eigen::Map<const Positions>(on.data(), 3, net_.topo.num_vertices);
  } else {
    static_cast<HmcState&>(state_) = hmc_state(potential_, flat(x));
    state_.fixman = 0.0;
    x_ = x;
  }
  if (!std::isfinite(state_.potential))
    throw std::invalid_argument(
        "Monte Carlo start is infeasible (a link at Lmax or a collapsed face)");
  const NetworkGeometry geo = network_geometry(x_, net_.topo);
  area_ = geo.area_um2;
  volume_ = geo.volume_um3;
}

int HmcSampler::mobile_vertices() const {
  return net_.topo.num_vertices;
}

double HmcSampler::energy() const {
  return (state_.potential - state_.fixman) / beta_;
}

McSweepStats HmcSampler::sweep() {
  const int steps = hmc_step_count(opt_.hmc, step_, rng_.get());
  if (constraints_) {
    const HmcConstrainedTransition c = hmc_constrained_transition(potential_, *constraints_, *mass_,
                                                                  state_, step_, steps, rng_.get());
    last_ = c.transition;
    failed_solves_ += c.failed_solves;
    failed_reverse_checks_ += c.failed_reverse_checks;
  } else {
    last_ = hmc_transition(potential_, *mass_, state_, step_, steps, rng_.get());
  }
  evaluations_ += last_.evaluations;
  solves_ += last_.solves;
  if (sweep_ < opt_.adapt_sweeps)
    step_ = hmc_adapted_step(opt_.hmc, step_, last_.acceptance_probability, sweep_);
  ++sweep_;
  if (last_.accepted) {
    x_ = Eigen::Map<const Positions>(state_.x.data(), 3, net_.topo.num_vertices);
    const NetworkGeometry geo = network_geometry(x_, net_.topo);
    area_ = geo.area_um2;
    volume_ = geo.volume_um3;
  }
  if (opt_.hmc.mass_reference == HmcMassReference::thermal) accumulate_reference();
  McSweepStats st;
  st.attempted = 1;
  st.accepted = last_.accepted ? 1 : 0;
  st.infeasible = last_.diverged ? 1 : 0;
  return st;
}

void HmcSampler::accumulate_reference() {
  // sweep_ transitions done: the last one is transition sweep_ - 1 (0-based).
  const long long k = sweep_ - 1;
  if (k < window_start() || k >= opt_.adapt_sweeps) return;
  if (k == window_start()) reference_sum_ = Positions::Zero(3, net_.topo.num_vertices);
  reference_sum_ += x_;
  if (k + 1 < opt_.adapt_sweeps) return;
  const long long count = opt_.adapt_sweeps - window_start();
  const Positions mean = reference_sum_ / double(count);
  reference_sum_.resize(3, 0);
  if (!std::isfinite(network_energy(net_, mean, load_))) return;  // M stays the start's
  std::unique_ptr<NetworkMassMatrix> rebuilt;
  try {
    rebuilt = std::make_unique<NetworkMassMatrix>(net_, load_, mean, beta_, opt_.hmc);
  } catch (const std::runtime_error&) {
    return;  // neither Hessian factorises at the mean: M stays the start's
  }
  mass_ = std::move(rebuilt);
  reference_ = mean;
  mass_info_ = mass_->info();
  mass_info_.thermal = true;
  mass_info_.reference_transitions = count;
}

McChainState HmcSampler::state() const {
  McChainState s;
  s.x = x_;
  s.step_um = step_;
  s.sweep = sweep_;
  const auto* p = static_cast<const unsigned char*>(gsl_rng_state(rng_.get()));
  s.rng_state.emplace_back(p, p + gsl_rng_size(rng_.get()));
  s.mass_reference = reference_;
  s.mass_reference_sum = reference_sum_;
  s.mass_at_thermal_mean = mass_info_.thermal;
  return s;
}

void HmcSampler::restore(const McChainState& s) {
  if (s.x.cols() != net_.topo.num_vertices)
    throw std::invalid_argument("chain state has " + std::to_string(s.x.cols()) +
                                " vertices, the network " + std::to_string(net_.topo.num_vertices));
  if (s.rng_state.size() != 1 || s.rng_state[0].size() != gsl_rng_size(rng_.get()))
    throw std::invalid_argument("chain state does not hold one mt19937 stream (HMC)");
  if (s.mass_reference.size() && s.mass_reference != reference_)
    throw std::invalid_argument("chain state's mass reference differs from the sampler's");
  if (!(s.step_um > 0) || !std::isfinite(s.step_um) || s.sweep < 0)
    throw std::invalid_argument("chain state has an invalid step or sweep count");
  if (s.mass_at_thermal_mean &&
      (opt_.hmc.mass_reference != HmcMassReference::thermal || s.sweep < opt_.adapt_sweeps))
    throw std::invalid_argument(
        "chain state's mass matrix is at the thermal mean before the adaptive phase ended");
  const bool in_window = opt_.hmc.mass_reference == HmcMassReference::thermal &&
                         s.sweep > window_start() && s.sweep < opt_.adapt_sweeps;
  if (in_window &&
      (s.mass_reference_sum.rows() != 3 || s.mass_reference_sum.cols() != net_.topo.num_vertices ||
       !s.mass_reference_sum.allFinite()))
    throw std::invalid_argument(
        "chain state inside the thermal mass reference's averaging window has no position sum");
  set_state(s.x);
  step_ = s.step_um;
  sweep_ = s.sweep;
  if (in_window)
    reference_sum_ = s.mass_reference_sum;
  else
    reference_sum_.resize(3, 0);
  // After the window the matrix is the thermal mean's, or the start's when the rebuild could not
  // be made there: the state says which.
  mass_info_.thermal = s.mass_at_thermal_mean;
  mass_info_.reference_transitions =
      s.mass_at_thermal_mean ? opt_.adapt_sweeps - window_start() : 0;
  std::memcpy(gsl_rng_state(rng_.get()), s.rng_state[0].data(), s.rng_state[0].size());
}

}  // namespace rbc
