// SPDX-License-Identifier: GPL-3.0-or-later
#include "calibrate/forward_model.hpp"

#include <omp.h>

#include <cmath>
#include <iomanip>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>

#include "calibrate/smooth_patch.hpp"
#include "continuum/continuum_stretch.hpp"
#include "core/blas_threads.hpp"  // OpenBLAS entry points (weak)
#include "core/geometry.hpp"
#include "core/units.hpp"
#include "discrete/stretch.hpp"
#include "homogenise/invariant_laws.hpp"

namespace rbc {

void use_single_threaded_blas() {
  if (!&openblas_set_num_threads) return;
  // OpenBLAS's OpenMP build (Debian's libopenblas0-openmp, what .ci/bootstrap.sh installs) also
  // sets OpenMP's thread count here: without restoring it every later parallel region, the
  // forward runs' executor included, ran on one thread (measured: `rbc infer` used one core
  // of two whatever OMP_NUM_THREADS said).
  const int omp_threads = omp_get_max_threads();
  openblas_set_num_threads(1);
  omp_set_num_threads(omp_threads);
}

void ForwardParameters::validate() const {
  if (!(persistence_nm > 0) || !std::isfinite(persistence_nm))
    throw std::invalid_argument("persistence length must be finite and > 0 nm, got " +
                                std::to_string(persistence_nm));
  if (!(lmax_nm > 75.0) || !std::isfinite(lmax_nm))
    throw std::invalid_argument("Lmax must be finite and > Lbar = 75 nm, got " +
                                std::to_string(lmax_nm));
  if (!(kappa_J > 0) || !std::isfinite(kappa_J))
    throw std::invalid_argument("bending rigidity must be finite and > 0 J, got " +
                                std::to_string(kappa_J));
  if (!(contact_fraction > 0 && contact_fraction < 0.5))
    throw std::invalid_argument("contact fraction must lie in (0, 0.5), got " +
                                std::to_string(contact_fraction));
}

void validate_method_force(MethodKind kind, double force_pN) {
  if (kind == MethodKind::discrete)
    validate_discrete_force(force_pN);
  else
    validate_continuum_force(force_pN);
}

double max_method_force_pN(MethodKind kind) {
  return kind == MethodKind::discrete ? kMaxDiscreteForce_pN : kMaxContinuumForce_pN;
}

void ForwardOptions::validate() const {
  if (forces_pN.empty()) throw std::invalid_argument("forward model needs at least one force");
  for (size_t k = 0; k < forces_pN.size(); ++k) {
    if (!std::isfinite(forces_pN[k]) || forces_pN[k] < 0)
      throw std::invalid_argument("force must be finite and >= 0 pN, got " +
                                  std::to_string(forces_pN[k]));
    if (k > 0 && !(forces_pN[k] > forces_pN[k - 1]))
      throw std::invalid_argument("forces must increase, got " + std::to_string(forces_pN[k]) +
                                  " after " + std::to_string(forces_pN[k - 1]));
    validate_method_force(method.kind, forces_pN[k]);
  }
  if (method.resolution <= 0)
    throw std::invalid_argument("method resolution must be > 0, got " +
                                std::to_string(method.resolution));
  newton.validate();
  if (pass_iterations < 1 || max_total_iterations < newton.max_iterations)
    throw std::invalid_argument("Newton passes of " + std::to_string(pass_iterations) +
                                " iterations up to " + std::to_string(max_total_iterations) +
                                " in all: need passes >= 1 and a total >= the first pass's " +
                                std::to_string(newton.max_iterations));
  if (!(diameter_tolerance_um > 0) || !std::isfinite(diameter_tolerance_um))
    throw std::invalid_argument("diameter tolerance must be finite and > 0 um, got " +
                                std::to_string(diameter_tolerance_um));
  if (!(accept_residual_pN > 0) || !std::isfinite(accept_residual_pN))
    throw std::invalid_argument("accepted residual must be finite and > 0 pN, got " +
                                std::to_string(accept_residual_pN));
  if (!(max_contraction > 0 && max_contraction < 1))
    throw std::invalid_argument("largest accepted contraction must lie in (0, 1), got " +
                                std::to_string(max_contraction));
  if (retry_bisections < 0)
    throw std::invalid_argument("retry bisections must be >= 0, got " +
                                std::to_string(retry_bisections));
}

namespace {
WlcParameters wlc_parameters(const ForwardParameters& p) {
  WlcParameters w;  // Lbar = 75 nm, T = 300 K
  w.persistence_um = units::nm_to_um(p.persistence_nm);
  w.lmax_um = units::nm_to_um(p.lmax_nm);
  return w;
}
}  // namespace

void apply_forward_parameters(Network& net, const ForwardParameters& p) {
  const double kappa = units::joule_to_pNum(p.kappa_J);
  net.wlc = make_wlc_density(wlc_parameters(p), WlcExpansion::full);
  net.steric_C_pN_per_um = steric_constant(net.wlc, net.steric);
  net.bending.kappa_pNum = kappa;
  net.dihedral_kb_pNum = dihedral_stiffness_pNum(kappa, DihedralMapping::sphere_matched);
  net.patch = smooth_tweezer_patch(net.rest, net.topo, p.contact_fraction);
}

void apply_forward_parameters(ContinuumModel& m, const ForwardParameters& p, WlcExpansion order) {
  m.law = make_membrane_law(wlc_parameters(p), StericParameters{}, order);
  m.bending.kappa_pNum = units::joule_to_pNum(p.kappa_J);
  m.patch = smooth_tweezer_patch(m.rest, m.topo, p.contact_fraction);
}

/// Immutable state shared by all workspaces.
struct ForwardModel::Shared {
  // discrete
  Network network;
  // continuum
  ContinuumModel continuum;
  int vertices = 0, elements = 0;
};

/// Outcome of one equilibrium solve.
struct SolveOutcome {
  bool converged = false;
  double residual_pN = 0;  ///< largest net vertex force at the end
  int iterations = 0;
  std::string status;               ///< solver status in words
  bool diameter_converged = false;  ///< accepted at the diameter tolerance
  bool symmetry_broken = false;     ///< the equilibrium is not mirror-symmetric
};

/// Mutable per-call state: the model with this call's parameters and its solver.
struct ForwardModel::Workspace {
  Network network;
  ContinuumModel continuum;
  std::unique_ptr<NewtonSolver> newton;
  /// The symmetric solver with every equilibrium checked (a saddle is pushed off and solved in
  /// full; an asymmetric start is solved in full): the forces of a run from its first unstable
  /// one on. Made on first use.
  std::unique_ptr<NewtonSolver> newton_checked;
  bool checked = false;  ///< solve with newton_checked
  /// Equilibrium at force F from x, lambda (updated in place; left at the start on failure).
  std::function<SolveOutcome(double, Positions&, ConstraintMultipliers&, const ProgressSink&)>
      solve;
};

ForwardModel::ForwardModel(const ForwardOptions& options)
    : options_(options), shared_(std::make_unique<Shared>()) {
  options_.validate();
  // The rest mesh (Phi minimisation) is assembled by OpenMP reductions: built on one thread
  // so its last bits, and with them every posterior sample, do not depend on OMP_NUM_THREADS.
  const int saved_threads = omp_get_max_threads();
  omp_set_num_threads(1);
  struct Restore {
    int n;
    ~Restore() { omp_set_num_threads(n); }
  } restore{saved_threads};
  if (options_.method.kind == MethodKind::discrete) {
    shared_->network = make_discrete_network(options_.method.resolution);
    shared_->vertices = shared_->network.topo.num_vertices;
    shared_->elements = shared_->network.topo.num_faces();
  } else {
    const TriMesh mesh = make_continuum_mesh(options_.method.resolution);
    const NetworkParameters defaults;
    shared_->continuum = build_continuum_model(
        mesh, make_membrane_law(defaults.wlc, defaults.steric, options_.method.order),
        ContinuumParameters{});
    shared_->vertices = shared_->continuum.topo.num_vertices;
    shared_->elements = shared_->continuum.num_elements();
  }
}

ForwardModel::~ForwardModel() = default;
int ForwardModel::vertices() const {
  return shared_->vertices;
}
int ForwardModel::elements() const {
  return shared_->elements;
}

std::unique_ptr<ForwardModel::Workspace> ForwardModel::borrow() const {
  {
    std::lock_guard<std::mutex> lock(pool_mutex_);
    if (!pool_.empty()) {
      auto ws = std::move(pool_.back());
      pool_.pop_back();
      return ws;
    }
  }
  auto ws = std::make_unique<Workspace>();
  if (options_.method.kind == MethodKind::discrete) {
    ws->network = shared_->network;
    Workspace* w = ws.get();
    ws->solve = [w](double f, Positions& x, ConstraintMultipliers& l, const ProgressSink& trace) {
      const Positions x0 = x;
      const ConstraintMultipliers l0 = l;
      StretchOptions so;
      so.precondition_min_vertices = std::numeric_limits<int>::max();  // no per-call factorisation
      const StretchPoint p = solve_equilibrium(w->network, f, x, l, so, trace);
      if (!p.converged) {
        x = x0;
        l = l0;
      }
      return SolveOutcome{p.converged, p.residual_pN, p.iterations, to_string(p.status)};
    };
  } else {
    ws->continuum = shared_->continuum;
    ws->newton = std::make_unique<NewtonSolver>(ws->continuum, options_.newton);
    Workspace* w = ws.get();
    const ForwardOptions o = options_;
    ws->solve = [w, o](double f, Positions& x, ConstraintMultipliers& l,
                       const ProgressSink& trace) {
      const Positions x0 = x;
      const ConstraintMultipliers l0 = l;
      NewtonSolver& solver = w->checked ? *w->newton_checked : *w->newton;
      NewtonResult r = solver.solve(f, x, l, trace);
      SolveOutcome out;
      out.iterations = r.iterations;
      int factorisations = r.factorisations;
      int krylov = r.krylov_iterations, fallbacks = r.krylov_fallbacks;
      double shift = r.largest_shift;
      // Continuation passes of a slow but converging solve (ForwardOptions).
      Diameters d = measure_diameters(x);
      double change_prev = std::numeric_limits<double>::infinity();
      double residual_prev = r.residual_pN;
      while (r.status == NewtonStatus::max_iterations && out.iterations < o.max_total_iterations) {
        NewtonLimits limits;
        limits.max_iterations =
            std::min(o.pass_iterations, o.max_total_iterations - out.iterations);
        r = solver.solve(f, x, l, trace, limits);
        out.iterations += r.iterations;
        factorisations += r.factorisations;
        krylov += r.krylov_iterations;
        fallbacks += r.krylov_fallbacks;
        shift = std::max(shift, r.largest_shift);
        if (r.status != NewtonStatus::max_iterations) break;  // converged or failed
        const Diameters dn = measure_diameters(x);
        const double change = std::max(std::abs(dn.axial_um - d.axial_um),
                                       std::abs(dn.transverse_um - d.transverse_um));
        d = dn;
        const double q = change / change_prev;
        if (q <= o.max_contraction && change * q / (1 - q) < o.diameter_tolerance_um &&
            r.residual_pN < o.accept_residual_pN) {
          out.diameter_converged = true;
          break;
        }
        if (!(r.residual_pN < residual_prev)) break;  // not converging: fail
        change_prev = change;
        residual_prev = r.residual_pN;
      }
      out.converged = r.converged() || out.diameter_converged;
      out.residual_pN = r.residual_pN;
      out.symmetry_broken = r.symmetry_broken;
      if (!out.converged) {
        x = x0;
        l = l0;
      }
      std::ostringstream status;
      status << (out.diameter_converged ? "diameters converged" : to_string(r.status)) << " ("
             << factorisations << " factorisations, largest shift " << shift << " x mean diagonal, "
             << krylov << " Krylov iterations, " << fallbacks << " shifted steps)";
      out.status = status.str();
      return out;
    };
  }
  return ws;
}

void ForwardModel::give_back(std::unique_ptr<Workspace> ws) const {
  std::lock_guard<std::mutex> lock(pool_mutex_);
  pool_.push_back(std::move(ws));
}

ForwardRun ForwardModel::run(const ForwardParameters& p, const WarmState& warm) const {
  return run(p, warm, ProgressSink{});
}

ForwardRun ForwardModel::run(const ForwardParameters& p, const WarmState& warm,
                             const ProgressSink& trace) const {
  p.validate();
  auto ws = borrow();
  struct Return {  // hands the workspace back on every path, exceptions included
    const ForwardModel* m;
    std::unique_ptr<Workspace>& w;
    ~Return() { m->give_back(std::move(w)); }
  } give{this, ws};
  const Positions* rest = nullptr;
  if (options_.method.kind == MethodKind::discrete) {
    apply_forward_parameters(ws->network, p);
    rest = &ws->network.rest;
  } else {
    // A factorisation kept from another sample's run would make this run's result depend on
    // which workspace it borrowed: start afresh (reuse across this run's forces only).
    ws->newton->forget_factorisation();
    if (ws->newton_checked) ws->newton_checked->forget_factorisation();
    apply_forward_parameters(ws->continuum, p, options_.method.order);
    rest = &ws->continuum.rest;
  }
  const int n = static_cast<int>(rest->cols());
  const int per_force = 3 * n + 2;
  const int nf = static_cast<int>(options_.forces_pN.size());
  const bool have_warm = static_cast<int>(warm.size()) == nf * per_force;
  if (!warm.empty() && !have_warm)
    throw std::invalid_argument("warm state of " + std::to_string(warm.size()) +
                                " values does not fit this forward model");
  // The forces from index `first` on, continuing `out` (whose forces before `first` are
  // solved; its state holds them).
  const auto sweep = [&](int first, ForwardRun out) {
    out.state.resize(static_cast<size_t>(nf) * per_force);
    Positions x_prev = *rest;
    ConstraintMultipliers l_prev;
    double f_prev = 0;
    if (first > 0) {
      const double* w = out.state.data() + static_cast<size_t>(first - 1) * per_force;
      x_prev = Eigen::Map<const Positions>(w, 3, n);
      l_prev = {w[3 * n], w[3 * n + 1]};
      f_prev = options_.forces_pN[first - 1];
      out.diameters.axial_um.resize(first);
      out.diameters.transverse_um.resize(first);
    } else {
      out.diameters = {};
    }
    out.converged = true;
    for (int k = first; k < nf; ++k) {
      const double f = options_.forces_pN[k];
      Positions x = x_prev;
      ConstraintMultipliers l = l_prev;
      bool predicted = false;
      const auto parent_start = [&] {
        const double* w = warm.data() + static_cast<size_t>(k) * per_force;
        x = Eigen::Map<const Positions>(w, 3, n);
        l.area_pN_per_um = w[3 * n];
        l.volume_pN_per_um2 = w[3 * n + 1];
      };
      if (have_warm) {
        parent_start();
        if (options_.predict_from_previous_force && k > 0) {
          // The parent's equilibrium plus this run's correction at the previous force.
          const double* wp = warm.data() + static_cast<size_t>(k - 1) * per_force;
          x += x_prev - Eigen::Map<const Positions>(wp, 3, n);
          l.area_pN_per_um += l_prev.area_pN_per_um - wp[3 * n];
          l.volume_pN_per_um2 += l_prev.volume_pN_per_um2 - wp[3 * n + 1];
          predicted = true;
        }
      }
      const auto attempt = [&](double force, const char* start) {
        const SolveOutcome o = ws->solve(force, x, l, trace);
        ++out.solves;
        if (trace) {
          std::ostringstream m;
          m << "solve F = " << force << " pN from " << start << ": " << o.status << " after "
            << o.iterations << " iterations, residual " << std::scientific << std::setprecision(3)
            << o.residual_pN << " pN";
          trace(m.str());
        }
        return o;
      };
      SolveOutcome o = attempt(f, predicted   ? "the predicted start"
                                  : have_warm ? "the parent's equilibrium"
                                              : "the previous force");
      if (predicted && !o.converged) {  // the plain parent's equilibrium before any retry
        parent_start();
        o = attempt(f, "the parent's equilibrium");
      }
      if (!o.converged) {
        // Retry: from this run's previous equilibrium through 2^b equal increments.
        out.retried = true;
        for (int b = 1; b <= options_.retry_bisections && !o.converged; ++b) {
          x = x_prev;
          l = l_prev;
          const int steps = 1 << b;
          o.converged = true;
          for (int s = 1; s <= steps && o.converged; ++s)
            o = attempt(f_prev + (f - f_prev) * s / steps, "a retry sub-step");
        }
      }
      out.residual_pN = std::max(out.residual_pN, o.residual_pN);
      out.diameter_converged += o.diameter_converged;
      out.symmetry_broken = out.symmetry_broken || o.symmetry_broken;
      if (!o.converged) {
        out.converged = false;
        out.failed_force_pN = f;
        std::ostringstream m;
        m << o.status << ", residual " << std::scientific << std::setprecision(3) << o.residual_pN
          << " pN";
        out.failure = m.str();
        out.state.clear();
        return out;
      }
      const Diameters d = measure_diameters(x);
      out.diameters.axial_um.push_back(d.axial_um);
      out.diameters.transverse_um.push_back(d.transverse_um);
      double* w = out.state.data() + static_cast<size_t>(k) * per_force;
      Eigen::Map<Positions>(w, 3, n) = x;
      w[3 * n] = l.area_pN_per_um;
      w[3 * n + 1] = l.volume_pN_per_um2;
      x_prev = std::move(x);
      l_prev = l;
      f_prev = f;
    }
    return out;
  };
  ForwardRun out = sweep(0, ForwardRun{});
  // The symmetric equilibria must be minima (ForwardOptions::check_symmetry_at_top_force).
  if (out.converged && options_.method.kind != MethodKind::discrete &&
      options_.newton.symmetry == Symmetry::mirror && options_.check_symmetry_at_top_force &&
      nf > 0) {
    const auto stable = [&](int k) {
      const double* w = out.state.data() + static_cast<size_t>(k) * per_force;
      const Positions x = Eigen::Map<const Positions>(w, 3, n);
      return ws->newton->check_symmetric_state(options_.forces_pN[k], x, {w[3 * n], w[3 * n + 1]})
          .stable;
    };
    if (!stable(nf - 1)) {
      // The first unstable force, by bisection (buckling grows with the stretch: stable below
      // it, unstable from it on). An asymmetric equilibrium (a buckled parent's start, solved
      // in full) is a full solve's and counts as stable.
      int lo = -1, hi = nf - 1;  // lo stable (or none), hi unstable
      while (hi - lo > 1) {
        const int mid = (lo + hi) / 2;
        (stable(mid) ? lo : hi) = mid;
      }
      if (trace) {
        std::ostringstream m;
        m << "the symmetric equilibria from F = " << options_.forces_pN[hi]
          << " pN on are saddles: solving those forces again, pushed off and in full";
        trace(m.str());
      }
      if (!ws->newton_checked) {
        NewtonOptions checked = options_.newton;
        checked.symmetry_check = true;
        ws->newton_checked = std::make_unique<NewtonSolver>(ws->continuum, checked);
      }
      ws->checked = true;
      struct Back {  // back to the unchecked solver on every path
        bool& flag;
        ~Back() { flag = false; }
      } back{ws->checked};
      out = sweep(hi, std::move(out));
      out.symmetry_broken = true;
    }
  }
  return out;
}

}  // namespace rbc
