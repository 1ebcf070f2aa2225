// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Metropolis Monte Carlo of the spectrin network at finite temperature: single-vertex
// moves with O(1) local energy differences, on exactly the free energy network_energy() gives
// the minimiser (MODEL.md section 2), sampled at beta = 1/(kB T), kB T from core/units.hpp.
//
// What the chain samples. pi(x) ~ exp(-beta F(x)) with F the model's list (model_terms):
//   F = links + steric + bending (Juelicher, dihedral, or custom terms' local pieces,
//       discrete/network.hpp LocalPieces) - tweezer work
//     + lambda_A (A - A0) + s kA/2 (A - A0)^2 + lambda_V (V - V0) + s kV/2 (V - V0)^2,
// the multipliers lambda held FIXED (typically those of the zero-temperature equilibrium, so
// that as T -> 0 the chain collapses onto the minimiser's equilibrium), kA, kV the network's
// penalty stiffnesses and s = LoadState::stiffness_scale. A and V are therefore held by a stiff
// quadratic well, not exactly: their thermal spread is sqrt(kB T / (s k)), about 5e-5 A0 and
// 7e-5 V0 at 300 K for s = 1, so runs that must keep the drift below 1e-4 (MODEL.md) raise s
// (McRunSetup::penalty_scale). Raising s at fixed lambda does not move the T = 0 minimum, whose
// violation is already < 1e-6.
//
// Parallel sweeps and detailed balance. The mobile vertices are coloured so that two
// vertices of one colour are at graph distance >= 3: a move at v changes the links and faces
// at v and the bending terms listed by bending_terms() (Juelicher cells of v and its 1-ring, or
// the hinges with v as an end or a wing), all of which read positions up to distance 2 only,
// so same-colour moves share no local term. The only coupling left is through
// the global quadratic A and V terms. Each colour pass therefore runs in two phases:
//   1. in parallel (one RNG stream per chunk of the colour): propose x_v' = x_v + step * U[-1,1]^3,
//      compute the LOCAL energy change and the area and volume changes dA_v, dV_v, draw u_v;
//   2. sequentially, in vertex order: accept with min(1, exp(-beta (dE_local + dE_global))) where
//      dE_global = G(A + dA_v, V + dV_v) - G(A, V) uses the EXACT running totals, which include
//      every move already accepted in this pass.
// The local change of v is unaffected by the other moves of its colour, so phase 2 is exactly a
// sequential Metropolis sweep through the colour in fixed order: every single-vertex update
// satisfies detailed balance with respect to pi, with no linearisation of the global terms.
// The chain depends on (seed, streams) only, never on the number of OpenMP threads.
//
// Running totals A and V are updated incrementally per accepted move and re-summed from the
// per-face caches (a fixed-order sum, so bit-reproducible) at the start of every sweep; the largest
// incremental drift seen is reported. Bending terms are cached and the few a move changes are
// recomputed from scratch on each accepted move (no drift).
//
// Step size: during the first adapt_sweeps sweeps the step follows
// log(step) += adapt_gain n/(n + 200) (acceptance - target) (n moves in the sweep), then it is
// frozen (production); adaptation breaks detailed balance, so samples from that phase are flagged
// and not used for means.
#include <gsl/gsl_rng.h>

#include <memory>
#include <string>
#include <vector>

#include "discrete/hmc_kernel.hpp"
#include "discrete/network.hpp"

namespace rbc {

/// The Markov chain of a Monte Carlo run. Both sample the same law (the free energy and fixed
/// multipliers above, at the sampling temperature); spelled "metropolis", "hmc" on the command
/// line and in Python.
enum class McAlgorithm {
  /// Single-vertex Metropolis moves (this file): the reference sampler; a sweep offers every
  /// mobile vertex one move.
  metropolis,
  /// Hamiltonian Monte Carlo of all vertices at once with the Hessian at the start as mass
  /// matrix (discrete/hmc_sampler.hpp); a sweep is one trajectory.
  hmc,
};
std::string to_string(McAlgorithm a);
/// Throws std::invalid_argument ("sampler 'x' is not one of metropolis, hmc").
McAlgorithm mc_algorithm_from_string(const std::string& s);

struct McOptions {
  /// Which chain samples the law (HMC needs temperature_K > 0 and all vertices mobile).
  McAlgorithm algorithm = McAlgorithm::metropolis;
  /// The HMC transition (algorithm == hmc): step, trajectory time, jitter, target acceptance
  /// and gain of the step adaptation (adapt_sweeps trajectories long). Ignored by Metropolis.
  HmcOptions hmc;
  double temperature_K = 300.0;  ///< sampling temperature, K; 0 = quench (downhill moves only)
  unsigned long seed = 1;        ///< seed of the GSL mt19937 streams
  /// Independent RNG streams = parallel chunks per colour (the chain depends on it, not on the
  /// number of threads). Default 1. HMC uses one stream whatever this says (McRun sets 1).
  int streams = 1;
  /// OpenMP threads of the sweeps: 0 = mc_thread_decision() (one thread at the sizes the
  /// sampler runs today); k > 0 = min(k, streams), whatever the size (benchmarks and the
  /// thread-independence tests). The chain never depends on it.
  int threads = 0;
  /// Initial half-width of the uniform trial displacement per coordinate (um);
  /// 0 selects 0.01 x the shortest rest link.
  double initial_step_um = 0.0;
  int adapt_sweeps = 0;            ///< sweeps with adaptive step (equilibration), then frozen
  double target_acceptance = 0.4;  ///< adaptation target (the 30-50 % band)
  double adapt_gain =
      0.5;  ///< log-step change per unit acceptance error, per sweep of >> 200 moves
  /// Vertices that move (empty = all). Others stay fixed (used by the detailed-balance test).
  std::vector<int> mobile;
  /// Independent chains of a run (McRun, discrete/mc_run.hpp), in [1, kMaxMcChains]: chain c
  /// is its own McSampler or HmcSampler seeded with mc_chain_seed(seed, c), all started at the
  /// same state. Fixed (two by default, whatever the thread count), so a run's results never
  /// depend on the threads. A single McSampler or HmcSampler ignores it; McRunSetup::validate()
  /// checks it.
  int chains = 2;
  /// Throws std::invalid_argument (rbc::InvalidParameter) naming the value, every number finite:
  /// T in [0, kMaxSamplingTemperature_K] K, streams in [1, kMaxMcStreams], step in [0, 1] um,
  /// adapt_sweeps >= 0, target in (0, 1), gain in [0, 10], threads in [0, kMaxMcStreams].
  void validate() const;
};

/// Fewest mobile vertices for which the sweeps run on more than one thread. A sweep is a
/// sequence of colour passes (12-13 colours at every size), each two barriers apart, and the
/// work of one pass is small: on the 2-core machine two threads ran the sweeps of `rbc bench
/// mc` 0.83x as fast as one at N = 500, 1.02x at 2,000 and 1.12x at 8,000 when it was idle, and
/// 0.1x-0.6x (N = 500 to 32,000) beside other busy processes, where every barrier waits for a
/// descheduled thread. So every network `rbc mc` accepts (N <= 40,000) samples on one thread.
inline constexpr int kMcParallelVertices = 50000;

/// How many OpenMP threads the sweeps use, and why (recorded in the run's outputs).
struct McThreadDecision {
  int threads = 1;     ///< threads the sweeps run on
  int requested = 1;   ///< threads available to the caller (omp_get_max_threads())
  std::string reason;  ///< e.g. "1: a second thread does not pay below N = 50000 vertices"
};

/// The thread decision for `mobile_vertices` moving vertices, `streams` RNG streams (at most
/// one thread per stream), `requested_threads` available and `forced_threads` (McOptions::
/// threads: 0 = decide, k > 0 = min(k, streams)).
McThreadDecision mc_thread_decision(int mobile_vertices, int streams, int requested_threads,
                                    int forced_threads = 0);

/// Largest sampling temperature (K). Far above any physical temperature of the cell: `rbc
/// stability` samples up to 30,000 K to show where the area/volume penalties stop holding.
inline constexpr double kMaxSamplingTemperature_K = 1e5;

/// Largest number of RNG streams (parallel chunks per colour).
inline constexpr int kMaxMcStreams = 1024;

/// Largest number of independent chains of a run (McOptions::chains).
inline constexpr int kMaxMcChains = 16;

/// Everything that defines the chain at a sweep boundary (what a checkpoint holds).
struct McChainState {
  Positions x;                                        ///< 3 x N, um
  std::vector<std::vector<unsigned char>> rng_state;  ///< gsl_rng_state bytes, per stream
  /// Metropolis: the trial half-width (um); HMC: the leapfrog step (dimensionless time).
  double step_um = 0;
  long long sweep = 0;  ///< completed sweeps
  /// HMC: the positions the mass matrix was built at (3 x N, um); empty for Metropolis.
  Positions mass_reference;
  /// HMC with the thermal mass reference, inside the averaging window (second half of the
  /// adaptive phase): the sum of the chain's positions after each transition of the window so
  /// far (3 x N, um); empty otherwise.
  Positions mass_reference_sum;
  /// HMC: the mass matrix in use was built at the thermal mean (HmcMassReference::thermal after
  /// the adaptive phase); false while it is the start's, also when the rebuild at the mean could
  /// not be made (an infeasible mean, or no Hessian factorised there) and the start's was kept.
  bool mass_at_thermal_mean = false;
};

/// Counts of one sweep.
struct McSweepStats {
  long long attempted = 0, accepted = 0, infeasible = 0;
  double acceptance() const { return attempted ? double(accepted) / double(attempted) : 0.0; }
};

/// Energy change of a single-vertex move, split as the sampler uses it.
struct McMoveDelta {
  bool feasible = true;   ///< false: a link at/past Lmax or a collapsed face (rejected)
  double local_pNum = 0;  ///< change of links + steric + bending + tweezer work
  double area_um2 = 0;    ///< change of the total area
  double volume_um3 = 0;  ///< change of the enclosed volume
};

/// Area/volume part of F as a function of the totals:
///   G(A, V) = lA (A - A0) + s kA/2 (A - A0)^2 + lV (V - V0) + s kV/2 (V - V0)^2   [pN um]
/// with s = load.stiffness_scale (the formula network_energy() uses, evaluated from running
/// totals instead of positions).
double constraint_energy_of_totals(const Network& net, const LoadState& load, double area_um2,
                                   double volume_um3);

/// The local bending terms of the network's model and which of them a single-vertex move
/// changes: Juelicher vertex cells (term = vertex; a move at v changes v and its 1-ring) or
/// Kantor-Nelson hinges (term = edge; a move at v changes its incident edges and the edge
/// opposite v in each incident face). terms[offsets[v] .. offsets[v+1]) lists v's terms.
struct BendingTerms {
  int count = 0;  ///< number of terms (N or E)
  std::vector<int> offsets, terms;
};
/// The production bending term of the model's list (model_terms): Juelicher cells, dihedral
/// hinges, or none (count 0) when the list has no production bending term.
BendingTerms bending_terms(const Network& net);
/// A custom term's pieces as a stencil: term = piece, v's terms are the pieces listing v.
/// Throws std::invalid_argument for a vertex out of range or a piece whose vertices are not
/// pairwise within graph distance 2.
BendingTerms piece_stencil(const Topology& topo, const PieceLayout& layout);
/// Juelicher stencil: term = vertex cell; v's terms are v and its neighbours.
BendingTerms vertex_cell_stencil(const Topology& topo);
/// Hinge stencil: term = edge; v's terms are its incident edges (vertex_edges order), then the
/// edge opposite v in each incident face (vertex_faces order).
BendingTerms hinge_stencil(const Topology& topo);

/// Greedy distance-d colouring of `vertices` (all if empty): two vertices of one colour are at
/// graph distance >= min_distance. Colours are vertex lists in increasing order.
std::vector<std::vector<int>> colour_vertices(const Topology& topo, int min_distance,
                                              const std::vector<int>& vertices = {});

/// What a Monte Carlo run needs of its chain (McSampler, HmcSampler): advance by one sweep,
/// the state and its observables, checkpointable state.
class McChain {
 public:
  virtual ~McChain() = default;
  /// One sweep: Metropolis, every mobile vertex offered one move; HMC, one trajectory
  /// (attempted 1, accepted 0 or 1, infeasible 1 when it left the domain).
  virtual McSweepStats sweep() = 0;
  /// The sampled free energy F at the current state (pN um), bit-reproducible for any thread
  /// count.
  virtual double energy() const = 0;
  virtual const Positions& positions() const = 0;
  /// Metropolis: trial half-width (um); HMC: leapfrog step (dimensionless time).
  virtual double step_um() const = 0;
  virtual long long sweeps_done() const = 0;
  virtual double area_um2() const = 0;
  virtual double volume_um3() const = 0;
  virtual const McThreadDecision& thread_decision() const = 0;
  /// Largest |running - recomputed| of A (um^2) and V (um^3) (0 where totals are recomputed).
  virtual double max_area_drift_um2() const = 0;
  virtual double max_volume_drift_um3() const = 0;
  /// Vertices that move.
  virtual int mobile_vertices() const = 0;
  /// Metropolis: the colour classes of a sweep; HMC: 0.
  virtual int colour_count() const = 0;
  virtual McAlgorithm algorithm() const = 0;
  virtual McChainState state() const = 0;
  /// Restores a state written by state() of the same kind of chain; std::invalid_argument when
  /// it does not fit.
  virtual void restore(const McChainState& s) = 0;
};

/// The Metropolis sampler. Owns the prepared state (colouring, RNG streams, caches); the
/// network must outlive it.
class McSampler final : public McChain {
 public:
  /// Starts the chain at `start` (must be feasible) with fresh streams seeded from options.seed.
  /// Throws std::invalid_argument for invalid options or an infeasible start. The area and
  /// volume penalties are those of network_energy() at `load` (stiffness_scale included).
  McSampler(const Network& net, const LoadState& load, const Positions& start,
            const McOptions& options);
  McSampler(const McSampler&) = delete;
  McSampler& operator=(const McSampler&) = delete;

  /// One sweep: every mobile vertex is offered one move, colour by colour.
  McSweepStats sweep() override;

  /// Local-update energy change of moving v to `to` at the current state, including the
  /// global area/volume term from the running totals (pN um); +inf when infeasible.
  double move_energy_change(int v, const Eigen::Vector3d& to);
  /// The split change (without the global term).
  McMoveDelta move_delta(int v, const Eigen::Vector3d& to);

  /// The sampled free energy F at the current state (pN um): the cached local terms (exact
  /// kernel values) summed in a fixed order, plus tweezers and the area/volume terms. It is
  /// bit-reproducible for any thread count and agrees with network_energy() to round-off.
  double energy() const override;

  const Positions& positions() const override { return x_; }
  double step_um() const override { return step_; }
  long long sweeps_done() const override { return sweep_; }
  double area_um2() const override { return area_; }
  double volume_um3() const override { return volume_; }
  double beta_per_pNum() const { return beta_; }
  const LoadState& load() const { return load_; }
  const McOptions& options() const { return opt_; }
  const std::vector<std::vector<int>>& colours() const { return colours_; }
  /// The threads the sweeps run on (mc_thread_decision at construction).
  const McThreadDecision& thread_decision() const override { return threads_; }
  /// Largest |running - recomputed| of A (um^2) and V (um^3) seen at the per-sweep resets.
  double max_area_drift_um2() const override { return max_area_drift_; }
  double max_volume_drift_um3() const override { return max_volume_drift_; }
  int mobile_vertices() const override;
  int colour_count() const override { return static_cast<int>(colours_.size()); }
  McAlgorithm algorithm() const override { return McAlgorithm::metropolis; }

  McChainState state() const override;
  /// Restores a state written by state() (same network, same streams); throws
  /// std::invalid_argument if shapes or RNG sizes differ, or if x is infeasible.
  void restore(const McChainState& s) override;

 private:
  struct Proposal {
    Eigen::Vector3d to;
    McMoveDelta delta;
    double u = 0;
  };
  void propose(int v, const Eigen::Vector3d& to, McMoveDelta& d);
  void commit(int v, const Eigen::Vector3d& to);  ///< accepts v's last proposal
  void recompute_totals();
  double steric_of_area(int f, double area_um2) const;

  const Network& net_;
  LoadState load_;
  McOptions opt_;
  double beta_ = 0;  ///< 1/(kB T) in 1/(pN um); +inf at T = 0
  Positions x_;
  double step_ = 0, min_step_ = 0, max_step_ = 0;
  long long sweep_ = 0;
  double area_ = 0, volume_ = 0;
  double max_area_drift_ = 0, max_volume_drift_ = 0;
  std::vector<std::vector<int>> colours_;
  McThreadDecision threads_;
  struct RngFree {
    void operator()(gsl_rng* r) const noexcept { gsl_rng_free(r); }
  };
  /// One owned mt19937 per stream: freed on every path (a constructor that throws after
  /// allocating them, e.g. restore() refusing a corrupt state, leaks nothing).
  std::vector<std::unique_ptr<gsl_rng, RngFree>> rng_;
  // Caches of the local terms at x_ (exact kernel values, refreshed on every accepted move)
  // and, aligned with each vertex's stencil slots, the values of its pending proposal.
  BendingTerms bend_terms_;          ///< bending terms a move changes (bending_terms())
  BendingTerms hinges_;              ///< Juelicher: hinges a move changes (hinge_stencil())
  std::vector<double> bend_;         ///< energy of each bending term (pN um)
  std::vector<double> link_e_;       ///< link energy per edge (pN um)
  std::vector<double> lt_;           ///< Juelicher: L_e theta_e per edge (um)
  std::vector<double> face_area_;    ///< per face (um^2)
  std::vector<double> face_volume_;  ///< signed tetrahedron volume per face (um^3)
  std::vector<double> steric_;       ///< steric energy per face (pN um)
  std::vector<double> bend_new_;     ///< aligned with bend_terms_.terms
  std::vector<double> lt_new_;       ///< aligned with hinges_.terms
  std::vector<double> link_new_;     ///< aligned with topo.vertex_edges.items
  std::vector<double> area_new_, volume_new_, steric_new_;  ///< aligned with vertex_faces.items
  std::vector<Proposal> proposal_;                          ///< per vertex
  std::vector<int> tweezer_slot_;                           ///< index into tweezer_single_ or -1
  std::vector<TweezerPatch> tweezer_single_;
  bool juelicher_ = false;  ///< the list's production bending term is Juelicher's
  struct CustomPieces {     ///< a custom term's local pieces (NetworkTerm::pieces)
    const NetworkTerm* term = nullptr;
    BendingTerms stencil;         ///< piece_stencil
    std::vector<double> cache;    ///< e_p at x_ (pN um)
    std::vector<double> pending;  ///< aligned with stencil.terms
  };
  std::vector<CustomPieces> custom_;
};

}  // namespace rbc
