// SPDX-License-Identifier: GPL-3.0-or-later
#include "discrete/mc_sampler.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>

#include "core/geometry.hpp"
#include "core/units.hpp"
#include "core/validation.hpp"
#include "discrete/bending_energy.hpp"
#include "discrete/link_energy.hpp"
#include "discrete/steric_energy.hpp"
#include "discrete/tweezers.hpp"

namespace rbc {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// SplitMix64 (Steele, Lea & Flood 2014): decorrelates the per-stream seeds derived from one seed.
std::uint64_t splitmix64(std::uint64_t z) {
  z += 0x9E3779B97F4A7C15ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

}  // namespace

std::string to_string(McAlgorithm a) {
  return a == McAlgorithm::hmc ? "hmc" : "metropolis";
}

McAlgorithm mc_algorithm_from_string(const std::string& s) {
  if (s == "metropolis") return McAlgorithm::metropolis;
  if (s == "hmc") return McAlgorithm::hmc;
  throw std::invalid_argument("sampler '" + s + "' is not one of metropolis, hmc");
}

void McOptions::validate() const {
  require_finite_in_range("sampling temperature", "K", temperature_K, 0.0,
                          kMaxSamplingTemperature_K, Ends::closed_closed);
  if (algorithm == McAlgorithm::hmc) {
    require_finite_in_range("HMC sampling temperature", "K", temperature_K, 0.0,
                            kMaxSamplingTemperature_K, Ends::open_closed);
    hmc.validate();
    if (hmc.mass_reference == HmcMassReference::thermal && adapt_sweeps < 2)
      throw InvalidParameter("adaptive sweeps", std::to_string(adapt_sweeps),
                             ">= 2 (the thermal HMC mass reference averages the positions over "
                             "the second half of the adaptive phase)");
    if (!mobile.empty())
      throw InvalidParameter("mobile vertices", std::to_string(mobile.size()),
                             "all (HMC moves every vertex; a subset needs the metropolis sampler)");
  }
  require_integer_in_range("RNG streams", streams, 1, kMaxMcStreams);
  // A trial step beyond 1 um (a quarter of the cell's radius) can only be rejected.
  require_finite_in_range("initial Monte Carlo step", "um", initial_step_um, 0.0, 1.0,
                          Ends::closed_closed);
  require_integer_in_range("adaptive sweeps", adapt_sweeps, 0, std::numeric_limits<int>::max());
  require_finite_in_range("target acceptance", "", target_acceptance, 0.0, 1.0, Ends::open_open);
  require_finite_in_range("step adaptation gain", "", adapt_gain, 0.0, 10.0, Ends::closed_closed);
  require_integer_in_range("Monte Carlo threads", threads, 0, kMaxMcStreams);
}

McThreadDecision mc_thread_decision(int mobile_vertices, int streams, int requested_threads,
                                    int forced_threads) {
  McThreadDecision d;
  d.requested = std::max(1, requested_threads);
  auto say = [&](int threads, const std::string& why) {
    d.threads = threads;
    d.reason = std::to_string(threads) + ": " + why;
    return d;
  };
  if (forced_threads > 0) {
    const int t = std::max(1, std::min(forced_threads, streams));
    return say(t, "set by the caller (" + std::to_string(forced_threads) + " threads, " +
                      std::to_string(streams) + " RNG streams)");
  }
  if (d.requested == 1) return say(1, "one thread requested (OMP_NUM_THREADS)");
  if (streams <= 1) return say(1, "one RNG stream, so one chunk per colour");
  if (mobile_vertices < kMcParallelVertices)
    return say(1, "a second thread does not pay below N = " + std::to_string(kMcParallelVertices) +
                      " vertices");
  return say(std::min(d.requested, streams), std::to_string(mobile_vertices) +
                                                 " vertices, at least " +
                                                 std::to_string(kMcParallelVertices) + ", on " +
                                                 std::to_string(streams) + " RNG streams");
}

double constraint_energy_of_totals(const Network& net, const LoadState& load, double area,
                                   double volume) {
  ConstraintParameters penalty = net.constraints;
  penalty.area_stiffness_pN_per_um3 *= load.stiffness_scale;
  penalty.volume_stiffness_pN_per_um5 *= load.stiffness_scale;
  return constraint_energy_of_totals(area, volume, net.area0_um2, net.volume0_um3, penalty,
                                     load.multipliers);
}

BendingTerms vertex_cell_stencil(const Topology& t) {
  // The Juelicher energy of w reads w's 1-ring, so a move at v changes the cells of v and of
  // its neighbours.
  const int n = t.num_vertices;
  BendingTerms bt;
  bt.count = n;
  bt.offsets.assign(n + 1, 0);
  for (int v = 0; v < n; ++v) {
    bt.terms.push_back(v);
    for (const int* w = t.vertex_neighbours.begin(v); w != t.vertex_neighbours.end(v); ++w)
      bt.terms.push_back(*w);
    bt.offsets[v + 1] = static_cast<int>(bt.terms.size());
  }
  return bt;
}

BendingTerms hinge_stencil(const Topology& t) {
  // v is an end of its incident edges (in vertex_edges order) and the wing vertex of the edge
  // opposite it in each incident face (in vertex_faces order).
  const int n = t.num_vertices;
  BendingTerms bt;
  bt.count = t.num_edges();
  bt.offsets.assign(n + 1, 0);
  for (int v = 0; v < n; ++v) {
    for (const int* e = t.vertex_edges.begin(v); e != t.vertex_edges.end(v); ++e)
      bt.terms.push_back(*e);
    for (const int* f = t.vertex_faces.begin(v); f != t.vertex_faces.end(v); ++f) {
      const auto& c = t.faces.col(*f);
      const int k = c(0) == v ? 0 : c(1) == v ? 1 : 2;
      const int p = c((k + 1) % 3), q = c((k + 2) % 3);
      for (const int* h = t.vertex_edges.begin(p); h != t.vertex_edges.end(p); ++h)
        if (t.edges(0, *h) == q || t.edges(1, *h) == q) bt.terms.push_back(*h);
    }
    bt.offsets[v + 1] = static_cast<int>(bt.terms.size());
  }
  return bt;
}

BendingTerms bending_terms(const Network& net) {
  // The production bending term of the model's list (model_terms), if any.
  if (has_term(net, TermKind::juelicher_bending)) return vertex_cell_stencil(net.topo);
  if (has_term(net, TermKind::dihedral_bending)) return hinge_stencil(net.topo);
  BendingTerms none;
  none.offsets.assign(net.topo.num_vertices + 1, 0);
  return none;
}

BendingTerms piece_stencil(const Topology& t, const PieceLayout& layout) {
  const int n = t.num_vertices;
  std::vector<std::vector<int>> of(n);
  for (int p = 0; p < layout.count(); ++p)
    for (int k = layout.offsets[p]; k < layout.offsets[p + 1]; ++k) {
      const int v = layout.vertices[k];
      if (v < 0 || v >= n)
        throw std::invalid_argument("piece " + std::to_string(p) + " lists vertex " +
                                    std::to_string(v) + ", not in [0, " + std::to_string(n) + ")");
      if (of[v].empty() || of[v].back() != p) of[v].push_back(p);
    }
  // Same-colour moves (graph distance >= 3) must never share a piece.
  std::vector<int> near(n, -1);
  for (int p = 0; p < layout.count(); ++p)
    for (int k = layout.offsets[p]; k < layout.offsets[p + 1]; ++k) {
      const int a = layout.vertices[k];
      const int stamp = -2 - k;  // marks the distance <= 2 ball of vertex slot k
      near[a] = stamp;
      for (const int* b = t.vertex_neighbours.begin(a); b != t.vertex_neighbours.end(a); ++b) {
        near[*b] = stamp;
        for (const int* c = t.vertex_neighbours.begin(*b); c != t.vertex_neighbours.end(*b); ++c)
          near[*c] = stamp;
      }
      for (int l = layout.offsets[p]; l < layout.offsets[p + 1]; ++l)
        if (near[layout.vertices[l]] != stamp)
          throw std::invalid_argument("piece " + std::to_string(p) + " couples vertices " +
                                      std::to_string(a) + " and " +
                                      std::to_string(layout.vertices[l]) +
                                      " more than two edges apart (the sampler's colouring "
                                      "needs pieces within graph distance 2)");
    }
  BendingTerms bt;
  bt.count = layout.count();
  bt.offsets.assign(n + 1, 0);
  for (int v = 0; v < n; ++v) {
    bt.terms.insert(bt.terms.end(), of[v].begin(), of[v].end());
    bt.offsets[v + 1] = static_cast<int>(bt.terms.size());
  }
  return bt;
}

std::vector<std::vector<int>> colour_vertices(const Topology& topo, int min_distance,
                                              const std::vector<int>& vertices) {
  if (min_distance < 1)
    throw std::invalid_argument("colouring distance must be >= 1, got " +
                                std::to_string(min_distance));
  const int n = topo.num_vertices;
  std::vector<int> order = vertices;
  if (order.empty())
    for (int v = 0; v < n; ++v) order.push_back(v);
  std::sort(order.begin(), order.end());
  std::vector<int> colour(n, -1), seen(n, -1), mark;
  std::vector<int> frontier, next;
  std::vector<std::vector<int>> classes;
  for (int v : order) {
    if (v < 0 || v >= n)
      throw std::invalid_argument("mobile vertex " + std::to_string(v) + " is not in [0, " +
                                  std::to_string(n) + ")");
    // Colours used within graph distance < min_distance of v (breadth-first search).
    mark.assign(classes.size() + 1, 0);
    frontier.assign(1, v);
    seen[v] = v;
    for (int d = 1; d < min_distance; ++d) {
      next.clear();
      for (int w : frontier)
        for (const int* u = topo.vertex_neighbours.begin(w); u != topo.vertex_neighbours.end(w);
             ++u)
          if (seen[*u] != v) {
            seen[*u] = v;
            next.push_back(*u);
            if (colour[*u] >= 0) mark[colour[*u]] = 1;
          }
      frontier.swap(next);
    }
    int c = 0;
    while (mark[c]) ++c;
    if (c == static_cast<int>(classes.size())) classes.emplace_back();
    colour[v] = c;
    classes[c].push_back(v);
  }
  return classes;
}

McSampler::McSampler(const Network& net, const LoadState& load, const Positions& start,
                     const McOptions& options)
    : net_(net), load_(load), opt_(options) {
  opt_.validate();
  if (start.cols() != net.topo.num_vertices)
    throw std::invalid_argument("start positions have " + std::to_string(start.cols()) +
                                " vertices, the network " + std::to_string(net.topo.num_vertices));
  const double kT = units::thermal_energy_pNum(opt_.temperature_K);
  beta_ = kT > 0 ? 1.0 / kT : kInf;
  const double lmin = net.lbar_um.minCoeff();
  step_ = opt_.initial_step_um > 0 ? opt_.initial_step_um : 0.01 * lmin;
  min_step_ = 1e-9 * lmin;
  max_step_ = 0.5 * lmin;
  step_ = std::clamp(step_, min_step_, max_step_);
  // Distance >= 3: see the header (Juelicher terms of a move at v read positions up to distance 2).
  colours_ = colour_vertices(net.topo, 3, opt_.mobile);
  const int n = net.topo.num_vertices;
  {
    int mobile = 0;
    for (const auto& c : colours_) mobile += static_cast<int>(c.size());
    threads_ = mc_thread_decision(mobile, opt_.streams, omp_get_max_threads(), opt_.threads);
  }
  // The model's list (model_terms): the production kinds the sampler's kernels cover, plus
  // custom terms with local pieces.
  for (TermKind k : {TermKind::in_plane, TermKind::area_volume, TermKind::tweezers})
    if (!has_term(net, k))
      throw std::invalid_argument(
          "the Monte Carlo sampler needs the in-plane, area/volume and tweezers terms; the "
          "model's list lacks one");
  juelicher_ = has_term(net, TermKind::juelicher_bending);
  if (juelicher_ && has_term(net, TermKind::dihedral_bending))
    throw std::invalid_argument("the Monte Carlo sampler takes one production bending term");
  for (const NetworkTerm& term : model_terms(net)) {
    if (term.kind != TermKind::custom) continue;
    if (!term.pieces.layout || !term.pieces.energy)
      throw std::invalid_argument("term \"" + term.name +
                                  "\" has no local pieces (LocalPieces::layout, energy): the "
                                  "Monte Carlo sampler needs its local energy changes");
    CustomPieces c;
    c.term = &term;
    c.stencil = piece_stencil(net.topo, term.pieces.layout(net));
    c.pending.assign(c.stencil.terms.size(), 0.0);
    custom_.push_back(std::move(c));
  }
  bend_terms_ = bending_terms(net);
  bend_new_.assign(bend_terms_.terms.size(), 0.0);
  if (juelicher_) {
    hinges_ = hinge_stencil(net.topo);
    lt_new_.assign(hinges_.terms.size(), 0.0);
  }
  link_new_.assign(net.topo.vertex_edges.items.size(), 0.0);
  area_new_.assign(net.topo.vertex_faces.items.size(), 0.0);
  volume_new_.assign(area_new_.size(), 0.0);
  steric_new_.assign(area_new_.size(), 0.0);
  proposal_.resize(n);
  tweezer_slot_.assign(n, -1);
  for (size_t k = 0; k < net.patch.vertex.size(); ++k) {
    TweezerPatch one;
    one.vertex = {net.patch.vertex[k]};
    one.share = {net.patch.share[k]};
    tweezer_slot_[net.patch.vertex[k]] = static_cast<int>(tweezer_single_.size());
    tweezer_single_.push_back(one);
  }
  for (int s = 0; s < opt_.streams; ++s) {
    rng_.emplace_back(gsl_rng_alloc(gsl_rng_mt19937));
    gsl_rng* r = rng_.back().get();
    if (!r) throw std::runtime_error("cannot allocate a GSL random number generator");
    gsl_rng_set(r, static_cast<unsigned long>(
                       splitmix64(std::uint64_t(opt_.seed) * 1024u + std::uint64_t(s)) >> 32) |
                       1ul);
  }
  McChainState s;
  s.x = start;
  s.step_um = step_;
  s.sweep = 0;
  for (const auto& r : rng_) {
    const auto* p = static_cast<const unsigned char*>(gsl_rng_state(r.get()));
    s.rng_state.emplace_back(p, p + gsl_rng_size(r.get()));
  }
  restore(s);
}

double McSampler::energy() const {
  // The caches hold each term's exact kernel value at x_, so this fixed-order sum is what a
  // from-scratch evaluation would give, without re-evaluating every term per sample.
  double e = 0;
  for (double v : link_e_) e += v;
  for (double v : steric_) e += v;
  for (double v : bend_) e += v;
  for (const CustomPieces& c : custom_)
    for (double v : c.cache) e += v;
  e += tweezers_energy(net_.patch, load_.force_pN, x_, net_.rest);
  return e + constraint_energy_of_totals(net_, load_, area_, volume_);
}

int McSampler::mobile_vertices() const {
  int n = 0;
  for (const auto& c : colours_) n += static_cast<int>(c.size());
  return n;
}

McChainState McSampler::state() const {
  McChainState s;
  s.x = x_;
  s.step_um = step_;
  s.sweep = sweep_;
  for (const auto& r : rng_) {
    const auto* p = static_cast<const unsigned char*>(gsl_rng_state(r.get()));
    s.rng_state.emplace_back(p, p + gsl_rng_size(r.get()));
  }
  return s;
}

void McSampler::restore(const McChainState& s) {
  if (s.x.cols() != net_.topo.num_vertices)
    throw std::invalid_argument("chain state has " + std::to_string(s.x.cols()) +
                                " vertices, the network " + std::to_string(net_.topo.num_vertices));
  if (s.rng_state.size() != rng_.size())
    throw std::invalid_argument("chain state has " + std::to_string(s.rng_state.size()) +
                                " RNG streams, the sampler " + std::to_string(rng_.size()));
  for (size_t k = 0; k < rng_.size(); ++k)
    if (s.rng_state[k].size() != gsl_rng_size(rng_[k].get()))
      throw std::invalid_argument("RNG state " + std::to_string(k) + " has " +
                                  std::to_string(s.rng_state[k].size()) + " bytes, mt19937 needs " +
                                  std::to_string(gsl_rng_size(rng_[k].get())));
  if (!(s.step_um > 0) || !std::isfinite(s.step_um) || s.sweep < 0)
    throw std::invalid_argument("chain state has an invalid step or sweep count");
  LoadState load = load_;
  if (!std::isfinite(network_energy(net_, s.x, load)))
    throw std::invalid_argument(
        "Monte Carlo start is infeasible (a link at Lmax or a collapsed face)");
  x_ = s.x;
  step_ = s.step_um;
  sweep_ = s.sweep;
  for (size_t k = 0; k < rng_.size(); ++k)
    std::memcpy(gsl_rng_state(rng_[k].get()), s.rng_state[k].data(), s.rng_state[k].size());
  // Caches of every local term at x_, each exactly the value its kernel gives (so sums of
  // cached and fresh values agree with a from-scratch evaluation to the last bit).
  const Topology& t = net_.topo;
  const int ne = t.num_edges(), nf = t.num_faces();
  link_e_.resize(ne);
#pragma omp parallel for schedule(static) num_threads(threads_.threads)
  for (int e = 0; e < ne; ++e)
    link_e_[e] =
        link_energy(net_.wlc, net_.lbar_um(e), x_.col(t.edges(0, e)), x_.col(t.edges(1, e)));
  face_area_.resize(nf);
  face_volume_.resize(nf);
  steric_.resize(nf);
#pragma omp parallel for schedule(static) num_threads(threads_.threads)
  for (int f = 0; f < nf; ++f) {
    const auto& c = t.faces.col(f);
    face_area_[f] = triangle_area(x_.col(c(0)), x_.col(c(1)), x_.col(c(2)));
    face_volume_[f] = tetra_volume(x_.col(c(0)), x_.col(c(1)), x_.col(c(2)));
    steric_[f] = steric_of_area(f, face_area_[f]);
  }
  bend_.resize(bend_terms_.count);
  if (juelicher_) {
    lt_.resize(ne);
#pragma omp parallel for schedule(static) num_threads(threads_.threads)
    for (int e = 0; e < ne; ++e) lt_[e] = hinge_length_angle(x_, t, e);
#pragma omp parallel for schedule(static) num_threads(threads_.threads)
    for (int w = 0; w < bend_terms_.count; ++w) {
      bend_[w] = juelicher_vertex_cell(
                     t, net_.bending, w, [&](int e) { return lt_[e]; },
                     [&](int f) { return face_area_[f]; })
                     .energy_pNum;
    }
  } else {  // dihedral hinges (bend_terms_.count = 0 without a production bending term)
#pragma omp parallel for schedule(static) num_threads(threads_.threads)
    for (int e = 0; e < bend_terms_.count; ++e)
      bend_[e] = dihedral_hinge_energy(x_, t, net_.dihedral_kb_pNum, 0.0, e);
  }
  for (CustomPieces& c : custom_) {
    c.cache.resize(c.stencil.count);
#pragma omp parallel for schedule(static) num_threads(threads_.threads)
    for (int p = 0; p < c.stencil.count; ++p) c.cache[p] = c.term->pieces.energy(net_, x_, p);
  }
  recompute_totals();
}

double McSampler::steric_of_area(int f, double area_um2) const {
  // steric_face_energy() from a known area: Abar_f s(A_f/Abar_f).
  const double abar = net_.abar_um2(f);
  return abar * steric_density(net_.steric_C_pN_per_um, net_.steric, area_um2 / abar).v;
}

void McSampler::recompute_totals() {
  // The per-face caches (exact kernel values at x_) summed in a fixed order: bit-reproducible
  // for any thread count, and equal to a from-scratch sum over the faces.
  double a = 0, vol = 0;
  for (std::size_t f = 0; f < face_area_.size(); ++f) {
    a += face_area_[f];
    vol += face_volume_[f];
  }
  if (sweep_ > 0 || area_ != 0) {
    max_area_drift_ = std::max(max_area_drift_, std::abs(area_ - a));
    max_volume_drift_ = std::max(max_volume_drift_, std::abs(volume_ - vol));
  }
  area_ = a;
  volume_ = vol;
}

namespace {
/// The new value of `id` if it is among the changed ids[lo, hi) (values aligned with ids),
/// else its cached value.
double changed_or_cached(int id, const std::vector<int>& ids, int lo, int hi,
                         const std::vector<double>& changed, const std::vector<double>& cached) {
  for (int k = lo; k < hi; ++k)
    if (ids[k] == id) return changed[k];
  return cached[id];
}
}  // namespace

void McSampler::propose(int v, const Eigen::Vector3d& to, McMoveDelta& d) {
  // Only x_v changes. Old values come from the caches; new ones are computed for the links and
  // faces at v, the hinges with v as an end or wing, and the bending terms of bending_terms(),
  // into v's own slots of the *_new_ arrays. Reads stay within graph distance 2 of v, so
  // concurrent proposals at same-colour vertices (distance >= 3) neither race nor interact.
  const Topology& t = net_.topo;
  d = McMoveDelta{};
  const int e_lo = t.vertex_edges.offsets[v], e_hi = t.vertex_edges.offsets[v + 1];
  const int f_lo = t.vertex_faces.offsets[v], f_hi = t.vertex_faces.offsets[v + 1];
  const TweezerPatch* bead = tweezer_slot_[v] >= 0 ? &tweezer_single_[tweezer_slot_[v]] : nullptr;
  double old_e = 0, old_a = 0, old_vol = 0;
  for (int k = e_lo; k < e_hi; ++k) old_e += link_e_[t.vertex_edges.items[k]];
  for (int k = f_lo; k < f_hi; ++k) {
    const int f = t.vertex_faces.items[k];
    old_e += steric_[f];
    old_a += face_area_[f];
    old_vol += face_volume_[f];
  }
  if (bead) old_e += tweezers_energy(*bead, load_.force_pN, x_, net_.rest);

  const Eigen::Vector3d from = x_.col(v);
  x_.col(v) = to;
  double new_e = 0, new_a = 0, new_vol = 0;
  bool feasible = true;
  for (int k = e_lo; k < e_hi && feasible; ++k) {
    const int e = t.vertex_edges.items[k];
    link_new_[k] =
        link_energy(net_.wlc, net_.lbar_um(e), x_.col(t.edges(0, e)), x_.col(t.edges(1, e)));
    feasible = link_new_[k] < kInf;
    new_e += link_new_[k];
  }
  for (int k = f_lo; k < f_hi && feasible; ++k) {
    const int f = t.vertex_faces.items[k];
    const auto& c = t.faces.col(f);
    area_new_[k] = triangle_area(x_.col(c(0)), x_.col(c(1)), x_.col(c(2)));
    feasible = area_new_[k] / net_.abar_um2(f) >= kCollapsedFaceRatio;  // network_energy's rule
    volume_new_[k] = tetra_volume(x_.col(c(0)), x_.col(c(1)), x_.col(c(2)));
    steric_new_[k] = steric_of_area(f, area_new_[k]);
    new_e += steric_new_[k];
    new_a += area_new_[k];
    new_vol += volume_new_[k];
  }
  if (!feasible) {
    x_.col(v) = from;
    d.feasible = false;
    return;
  }
  if (bead) new_e += tweezers_energy(*bead, load_.force_pN, x_, net_.rest);

  double bend_change = 0;
  const int b_lo = bend_terms_.offsets[v], b_hi = bend_terms_.offsets[v + 1];
  if (juelicher_) {
    // New L theta of the changed hinges, then the cells of v and its ring from their sums with
    // the changed hinges and faces substituted (juelicher_vertex_cell: the one home of the M_v, A_v
    // sums).
    const int h_lo = hinges_.offsets[v], h_hi = hinges_.offsets[v + 1];
    for (int k = h_lo; k < h_hi; ++k) lt_new_[k] = hinge_length_angle(x_, t, hinges_.terms[k]);
    for (int k = b_lo; k < b_hi; ++k) {
      const int w = bend_terms_.terms[k];
      bend_new_[k] =
          juelicher_vertex_cell(
              t, net_.bending, w,
              [&](int e) { return changed_or_cached(e, hinges_.terms, h_lo, h_hi, lt_new_, lt_); },
              [&](int f) {
                return changed_or_cached(f, t.vertex_faces.items, f_lo, f_hi, area_new_,
                                         face_area_);
              })
              .energy_pNum;
      bend_change += bend_new_[k] - bend_[w];
    }
  } else {
    for (int k = b_lo; k < b_hi; ++k) {
      const int e = bend_terms_.terms[k];
      bend_new_[k] = dihedral_hinge_energy(x_, t, net_.dihedral_kb_pNum, 0.0, e);
      bend_change += bend_new_[k] - bend_[e];
    }
  }
  for (CustomPieces& c : custom_)  // custom terms: the pieces that read x_v
    for (int k = c.stencil.offsets[v]; k < c.stencil.offsets[v + 1]; ++k) {
      const int p = c.stencil.terms[k];
      c.pending[k] = c.term->pieces.energy(net_, x_, p);
      bend_change += c.pending[k] - c.cache[p];
    }
  x_.col(v) = from;
  if (!std::isfinite(bend_change)) {
    d.feasible = false;
    return;
  }
  d.local_pNum = (new_e - old_e) + bend_change;
  d.area_um2 = new_a - old_a;
  d.volume_um3 = new_vol - old_vol;
}

void McSampler::commit(int v, const Eigen::Vector3d& to) {
  const Topology& t = net_.topo;
  x_.col(v) = to;
  for (int k = t.vertex_edges.offsets[v]; k < t.vertex_edges.offsets[v + 1]; ++k)
    link_e_[t.vertex_edges.items[k]] = link_new_[k];
  for (int k = t.vertex_faces.offsets[v]; k < t.vertex_faces.offsets[v + 1]; ++k) {
    const int f = t.vertex_faces.items[k];
    face_area_[f] = area_new_[k];
    face_volume_[f] = volume_new_[k];
    steric_[f] = steric_new_[k];
  }
  if (juelicher_)
    for (int k = hinges_.offsets[v]; k < hinges_.offsets[v + 1]; ++k)
      lt_[hinges_.terms[k]] = lt_new_[k];
  for (int k = bend_terms_.offsets[v]; k < bend_terms_.offsets[v + 1]; ++k)
    bend_[bend_terms_.terms[k]] = bend_new_[k];
  for (CustomPieces& c : custom_)
    for (int k = c.stencil.offsets[v]; k < c.stencil.offsets[v + 1]; ++k)
      c.cache[c.stencil.terms[k]] = c.pending[k];
}

McMoveDelta McSampler::move_delta(int v, const Eigen::Vector3d& to) {
  if (v < 0 || v >= net_.topo.num_vertices)
    throw std::invalid_argument("vertex " + std::to_string(v) + " out of range");
  McMoveDelta d;
  propose(v, to, d);
  return d;
}

double McSampler::move_energy_change(int v, const Eigen::Vector3d& to) {
  const McMoveDelta d = move_delta(v, to);
  if (!d.feasible) return kInf;
  return d.local_pNum +
         constraint_energy_of_totals(net_, load_, area_ + d.area_um2, volume_ + d.volume_um3) -
         constraint_energy_of_totals(net_, load_, area_, volume_);
}

McSweepStats McSampler::sweep() {
  recompute_totals();
  const int streams = opt_.streams;
  McSweepStats st;
  const double step = step_;
  // One region per sweep, two barriers per colour: on threads_.threads threads (at the sizes
  // the sampler runs today, one: see kMcParallelVertices).
#pragma omp parallel num_threads(threads_.threads)
  for (const std::vector<int>& cls : colours_) {
    const int m = static_cast<int>(cls.size());
    // Phase 1: proposals in parallel, stream s owns the contiguous chunk s of the colour.
#pragma omp for schedule(static)
    for (int s = 0; s < streams; ++s) {
      gsl_rng* r = rng_[s].get();
      const int lo = static_cast<int>(static_cast<long long>(m) * s / streams);
      const int hi = static_cast<int>(static_cast<long long>(m) * (s + 1) / streams);
      for (int i = lo; i < hi; ++i) {
        const int v = cls[i];
        Proposal& p = proposal_[v];
        for (int c = 0; c < 3; ++c) p.to(c) = x_(c, v) + step * (2.0 * gsl_rng_uniform(r) - 1.0);
        p.u = gsl_rng_uniform(r);
        propose(v, p.to, p.delta);
      }
    }
    // Phase 2: sequential acceptance with the exact global area/volume term.
#pragma omp single
    {
      double g_now = constraint_energy_of_totals(net_, load_, area_, volume_);
      for (const int v : cls) {
        const Proposal& p = proposal_[v];
        ++st.attempted;
        if (!p.delta.feasible) {
          ++st.infeasible;
          continue;
        }
        const double a = area_ + p.delta.area_um2, vol = volume_ + p.delta.volume_um3;
        const double g_new = constraint_energy_of_totals(net_, load_, a, vol);
        const double de = p.delta.local_pNum + (g_new - g_now);
        const bool accept = de <= 0 || (beta_ < kInf && p.u < std::exp(-beta_ * de));
        if (!accept) continue;
        ++st.accepted;
        commit(v, p.to);
        area_ = a;
        volume_ = vol;
        g_now = g_new;
      }
    }
  }
  ++sweep_;
  if (sweep_ <= opt_.adapt_sweeps && st.attempted > 0) {
    // Weight w = n/(n + 200): a sweep of n moves counts like a window of ~min(n, 200) moves,
    // so a handful of mobile vertices does not make the step jump (Robbins-Monro averaging).
    const double w = double(st.attempted) / (double(st.attempted) + 200.0);
    step_ *= std::exp(opt_.adapt_gain * w * (st.acceptance() - opt_.target_acceptance));
    step_ = std::clamp(step_, min_step_, max_step_);
  }
  return st;
}

}  // namespace rbc
