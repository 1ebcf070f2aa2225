// SPDX-License-Identifier: GPL-3.0-or-later
#include "compare/accuracy_study.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>

#include "compare/accuracy_choice.hpp"
#include "compare/plot.hpp"
#include "continuum/continuum_model.hpp"
#include "continuum/refined_mesh.hpp"
#include "core/io.hpp"
#include "core/validation.hpp"

namespace rbc {

const std::vector<double>& mills_forces_pN() {
  static const std::vector<double> forces{0,    16,    19.5, 30.6, 38,    46.6, 67.6,
                                          87.6, 108.8, 130,  151,  172.8, 193};
  return forces;
}

void AccuracyStudyOptions::validate() const {
  if (forces_pN.empty()) throw std::invalid_argument("accuracy study: the force list is empty");
  for (size_t k = 0; k < forces_pN.size(); ++k)
    if (!std::isfinite(forces_pN[k]) || forces_pN[k] < 0 ||
        (k > 0 && !(forces_pN[k] > forces_pN[k - 1])))
      throw std::invalid_argument(
          "accuracy study forces must be finite, >= 0 pN and increasing, got " +
          std::to_string(forces_pN[k]) + " pN at position " + std::to_string(k + 1));
  if (reference_seeds.empty())
    throw std::invalid_argument("accuracy study needs at least one reference triangulation");
  if (reference_vertices < 100 || reference_vertices > 40000)
    throw std::invalid_argument("reference vertices must be in [100, 40000], got " +
                                std::to_string(reference_vertices));
  if (!(reference_force_tolerance_pN >= 1e-8 && reference_force_tolerance_pN <= 1e-3)) {
    std::ostringstream m;
    m << "reference force tolerance must be in [1e-8, 1e-3] pN, got "
      << reference_force_tolerance_pN << " pN";
    throw std::invalid_argument(m.str());
  }
  if (symmetries.empty())
    throw std::invalid_argument("accuracy study needs at least one solver path (symmetry)");
  for (size_t k = 0; k < symmetries.size(); ++k)
    for (size_t j = 0; j < k; ++j)
      if (symmetries[j] == symmetries[k])
        throw std::invalid_argument("accuracy study: symmetry " + to_string(symmetries[k]) +
                                    " is listed twice");
  // The Richardson chains, the observed orders and the resolution plot read the full sweeps.
  if (std::find(symmetries.begin(), symmetries.end(), Symmetry::none) == symmetries.end())
    throw std::invalid_argument(
        "accuracy study: the solver paths must include none (the convergence study reads the "
        "full sweeps); got only mirror");
  for (int e : adapted_elements)
    if (e < kMinContinuumElements || e > kMaxContinuumElements)
      throw std::invalid_argument(
          "adapted-mesh elements must be in [" + std::to_string(kMinContinuumElements) + ", " +
          std::to_string(kMaxContinuumElements) + "], got " + std::to_string(e));
  if (!adapted_elements.empty()) {
    if (adapted_orders.empty() || adapted_size_ratios.empty())
      throw std::invalid_argument("accuracy study: adapted-mesh rows need a law and a size ratio");
    for (double r : adapted_size_ratios)
      if (!(r >= 1 && r <= 10)) {
        std::ostringstream m;
        m << "adapted-mesh size ratio must be in [1, 10], got " << r;
        throw std::invalid_argument(m.str());
      }
    if (adapted_seeds < 1 || adapted_seeds > 64)
      throw std::invalid_argument("adapted-mesh seeds must be in [1, 64], got " +
                                  std::to_string(adapted_seeds));
  }
  for (int e : refined_elements)
    if (e < kMinContinuumElements || e > kMaxContinuumElements)
      throw std::invalid_argument(
          "refined-mesh elements must be in [" + std::to_string(kMinContinuumElements) + ", " +
          std::to_string(kMaxContinuumElements) + "], got " + std::to_string(e));
  if (!refined_elements.empty()) {
    if (refined_orders.empty() || refined_size_ratios.empty())
      throw std::invalid_argument("accuracy study: refined-mesh rows need a law and a size ratio");
    for (double r : refined_size_ratios)
      if (!(r >= 1 && r <= 10)) {
        std::ostringstream m;
        m << "refined-mesh size ratio must be in [1, 10], got " << r;
        throw std::invalid_argument(m.str());
      }
  }
  for (int e : loop_elements)
    if (e < kMinContinuumElements || e > kMaxContinuumElements)
      throw std::invalid_argument(
          "Loop-element elements must be in [" + std::to_string(kMinContinuumElements) + ", " +
          std::to_string(kMaxContinuumElements) + "], got " + std::to_string(e));
  if (!loop_elements.empty() && loop_orders.empty())
    throw std::invalid_argument("accuracy study: Loop-element rows need a law");
  if (cost_unit_vertices < 100 || cost_unit_vertices > 40000)
    throw std::invalid_argument("cost-unit vertices must be in [100, 40000], got " +
                                std::to_string(cost_unit_vertices));
}

Richardson richardson_chain(double v1, double v2, double v3) {
  Richardson r;
  const double d12 = v1 - v2, d23 = v2 - v3;
  r.limit = v3;
  if (d12 == 0 || d23 == 0 || (d12 > 0) != (d23 > 0)) return r;  // no observed order
  r.order = std::log2(d12 / d23);
  r.clean = r.order >= 0.5 && r.order <= 4.0;
  if (r.clean) r.limit = v3 + (v3 - v2) / (std::pow(2.0, r.order) - 1.0);
  return r;
}

Richardson richardson_chain(double v1, double v2, double v3, double h_ratio) {
  Richardson r;
  const double d12 = v1 - v2, d23 = v2 - v3;
  r.limit = v3;
  if (!(h_ratio > 1) || d12 == 0 || d23 == 0 || (d12 > 0) != (d23 > 0)) return r;
  r.order = std::log(d12 / d23) / std::log(h_ratio);
  r.clean = r.order >= 0.5 && r.order <= 4.0;
  if (r.clean) r.limit = v3 + (v3 - v2) / (std::pow(h_ratio, r.order) - 1.0);
  return r;
}

double observed_order(const std::vector<double>& vertices, const std::vector<double>& errors) {
  const size_t n = std::min(vertices.size(), errors.size());
  if (n < 2) return 0;
  double mx = 0, my = 0;
  for (size_t k = 0; k < n; ++k)
    mx += -0.5 * std::log(vertices[k]) / n, my += std::log(errors[k]) / n;
  double sxy = 0, sxx = 0;
  for (size_t k = 0; k < n; ++k) {
    const double dx = -0.5 * std::log(vertices[k]) - mx;
    sxy += dx * (std::log(errors[k]) - my);
    sxx += dx * dx;
  }
  return sxx > 0 ? sxy / sxx : 0;
}

namespace {

/// Column code of a continuum law: 0 for the full law, else the Taylor order (2, 3, 4).
int order_code(WlcExpansion o) {
  return o == WlcExpansion::full ? 0 : std::stoi(to_string(o));
}

/// accuracy_cost.csv's columns (written and read back).
const std::vector<std::string>& accuracy_cost_header() {
  static const std::vector<std::string> h = {"kind",
                                             "order",
                                             "resolution",
                                             "vertices",
                                             "elements",
                                             "converged",
                                             "error_all",
                                             "error_low",
                                             "error_mid",
                                             "error_high",
                                             "cost_eg",
                                             "own_eg",
                                             "cpu_s",
                                             "wall_s",
                                             "spread",
                                             "rotations",
                                             "error_default",
                                             "reference_sd",
                                             "cost_unit_vertices",
                                             "symmetry"};
  return h;
}

/// Same method and resolution (any rotation).
bool same_family(const Method& a, const Method& b) {
  return a.kind == b.kind && a.resolution == b.resolution &&
         (a.kind == MethodKind::discrete ||
          (a.order == b.order && a.adapted == b.adapted && a.refined == b.refined &&
           a.loop == b.loop && (!(a.adapted || a.refined) || a.size_ratio == b.size_ratio)));
}

/// One sweep of the study: a discretisation and the solver path it is run with.
struct Sweep {
  Method method;
  Symmetry symmetry = Symmetry::none;
  bool reference = false;  ///< a reference sweep (its own tolerance), not a table entry
};

/// 0 none, 1 mirror: the symmetry column of the CSV files.
double symmetry_code(Symmetry s) {
  return s == Symmetry::mirror ? 1.0 : 0.0;
}

/// A tolerance as printed in messages and comments (shortest form, e.g. 1e-05).
std::string format_tolerance(double pN) {
  std::ostringstream m;
  m << pN;
  return m.str();
}

/// The cache file's base name: the method's name, "_mirror", and for a reference sweep
/// "_ref" with its force tolerance to 6 digits (e.g. discrete_N27500_r2_ref1e-05); the meta
/// file also stores the tolerance, which must match for the file to be reused.
std::string cache_base(const std::string& dir, const Method& m, Symmetry symmetry,
                       double reference_tolerance_pN) {
  std::string name = m.name() + (symmetry == Symmetry::mirror ? "_mirror" : "");
  if (reference_tolerance_pN > 0) {
    char tol[32];
    std::snprintf(tol, sizeof tol, "_ref%.6g", reference_tolerance_pN);
    name += tol;
  }
  return (std::filesystem::path(dir) / name).string();
}

void write_cached_run(const std::string& dir, const StudyRun& s, double reference_tolerance_pN) {
  const MethodRun& r = s.run;
  CsvTable pts;
  pts.comments = {"one sweep of the accuracy study: " + r.method.label() + ", rotation seed " +
                  std::to_string(r.method.rotation_seed) + ", symmetry " + to_string(r.symmetry) +
                  (s.reference ? ", reference sweep at force tolerance " +
                                     format_tolerance(reference_tolerance_pN) + " pN"
                               : "")};
  pts.header = {"force_pN",  "axial_um", "transverse_um", "iterations",
                "converged", "residual", "wall_s"};
  for (const auto& p : r.points)
    pts.rows.push_back({p.force_pN, p.axial_um, p.transverse_um, static_cast<double>(p.iterations),
                        p.converged ? 1.0 : 0.0, p.residual, p.wall_s});
  CsvTable meta;
  meta.comments = {"CPU times in s (process, all threads), areas in um^2"};
  meta.header = {"vertices",    "elements",        "cpu_s",          "wall_s",
                 "eval_cpu_s",  "unit_eval_cpu_s", "patch_plus_um2", "patch_minus_um2",
                 "surface_um2", "setup_s"};
  meta.rows.push_back({static_cast<double>(r.vertices), static_cast<double>(r.elements), r.cpu_s,
                       r.total_s - r.setup_s, r.eval_cpu_s, s.unit_eval_cpu_s, r.patch_plus_um2,
                       r.patch_minus_um2, r.surface_um2, r.setup_s});
  if (s.reference) {  // the reference sweeps' tolerance, checked when the file is read
    meta.header.push_back("force_tolerance_pN");
    meta.rows[0].push_back(reference_tolerance_pN);
  }
  const std::string base =
      cache_base(dir, r.method, r.symmetry, s.reference ? reference_tolerance_pN : 0.0);
  write_csv(base + ".meta.csv", meta);
  write_csv(base + ".csv", pts);  // written last: its presence marks a complete entry
}

bool read_cached_run(const std::string& dir, const Method& m, Symmetry symmetry,
                     double reference_tolerance_pN, const std::vector<double>& forces,
                     StudyRun& out) {
  const std::string base = cache_base(dir, m, symmetry, reference_tolerance_pN);
  if (!std::filesystem::exists(base + ".csv") || !std::filesystem::exists(base + ".meta.csv"))
    return false;
  const CsvTable pts = read_csv(base + ".csv");
  const CsvTable meta = read_csv(base + ".meta.csv");
  if (meta.rows.size() != 1 || meta.rows[0].size() < 10 || pts.rows.size() != forces.size())
    return false;
  // A reference sweep is reused only at the tolerance asked for (its name keeps 6 digits).
  if (reference_tolerance_pN > 0 &&
      (meta.rows[0].size() < 11 ||
       std::abs(meta.rows[0][10] - reference_tolerance_pN) > 1e-12 * reference_tolerance_pN))
    return false;
  for (size_t k = 0; k < forces.size(); ++k)
    if (pts.rows[k].size() < 7 || std::abs(pts.rows[k][0] - forces[k]) > 1e-9) return false;
  out.reference = reference_tolerance_pN > 0;
  MethodRun& r = out.run;
  r = MethodRun{};
  r.method = m;
  r.symmetry = symmetry;
  const auto& q = meta.rows[0];
  r.vertices = static_cast<int>(q[0]);
  r.elements = static_cast<int>(q[1]);
  r.cpu_s = q[2];
  r.setup_s = q[9];
  r.total_s = q[3] + q[9];
  r.eval_cpu_s = q[4];
  out.unit_eval_cpu_s = q[5];
  r.patch_plus_um2 = q[6];
  r.patch_minus_um2 = q[7];
  r.surface_um2 = q[8];
  for (const auto& p : pts.rows)
    r.points.push_back({p[0], p[1], p[2], p[6], p[5], static_cast<int>(p[3]), p[4] != 0});
  return true;
}

/// The list of sweeps the options ask for, cheapest first within each group. The default
/// triangulation (seed 0) is swept once per solver path, rotated ones in full only.
std::vector<Sweep> study_methods(const AccuracyStudyOptions& o) {
  std::vector<Sweep> out;
  auto add_one = [&](const Method& m, Symmetry symmetry, bool reference = false) {
    for (const auto& e : out)
      if (same_family(e.method, m) && e.method.rotation_seed == m.rotation_seed &&
          e.symmetry == symmetry && e.reference == reference)
        return;
    out.push_back({m, symmetry, reference});
  };
  auto add = [&](MethodKind kind, int resolution, WlcExpansion order, unsigned seed) {
    const Method m{kind, resolution, order, seed};
    if (seed != 0) return add_one(m, Symmetry::none);
    for (Symmetry sym : o.symmetries) add_one(m, sym);
  };
  for (int n : o.discrete_vertices) {
    add(MethodKind::discrete, n, WlcExpansion::full, 0);
    if (n <= o.spread_max_resolution)
      for (unsigned s : o.spread_seeds) add(MethodKind::discrete, n, WlcExpansion::full, s);
  }
  for (WlcExpansion order : o.continuum_orders)
    for (int e : o.continuum_elements) {
      if (order != WlcExpansion::order2 && e > o.full_law_max_elements) continue;
      add(MethodKind::continuum, e, order, 0);
      if (e <= o.spread_max_resolution)
        for (unsigned s : o.spread_seeds) add(MethodKind::continuum, e, order, s);
    }
  // The adapted mesh: every seed in full (no mirror to use).
  for (double ratio : o.adapted_size_ratios)
    for (WlcExpansion order : o.adapted_orders)
      for (int e : o.adapted_elements)
        for (int seed = 0; seed < o.adapted_seeds; ++seed) {
          Method m{MethodKind::continuum, e, order, static_cast<unsigned>(seed)};
          m.adapted = true;
          m.size_ratio = ratio;
          add_one(m, Symmetry::none);
        }
  // The refined mesh: as the uniform meshes (its default orientation keeps their mirrors). A
  // requested count whose mesh is one already planned at the same ratio is left out: the
  // smallest refined mesh is that of the coarsest icosphere (2,748 triangles at ratio 2), so
  // smaller requests give it again.
  std::set<std::pair<double, int>> refined_meshes;  // (size ratio, triangles)
  for (double ratio : o.refined_size_ratios)
    for (int e : o.refined_elements) {
      RefinedMeshOptions ro;
      ro.target_elements = e;
      ro.size_ratio = ratio;
      ro.contact_fraction = NetworkParameters{}.tweezers.contact_fraction;
      RefinedMeshReport rep;
      make_refined_mesh(ro, &rep);
      if (!refined_meshes.insert({ratio, rep.elements}).second) continue;
      for (WlcExpansion order : o.refined_orders) {
        Method m{MethodKind::continuum, e, order, 0};
        m.refined = true;
        m.size_ratio = ratio;
        for (Symmetry sym : o.symmetries) add_one(m, sym);
        for (unsigned s : o.spread_seeds) {
          m.rotation_seed = s;
          add_one(m, Symmetry::none);
        }
      }
    }
  // The Loop element: as the uniform meshes (its default orientation keeps their mirrors).
  for (WlcExpansion order : o.loop_orders)
    for (int e : o.loop_elements) {
      Method m{MethodKind::continuum, e, order, 0};
      m.loop = true;
      m.size_ratio = 1.0;  // a uniform mesh
      for (Symmetry sym : o.symmetries) add_one(m, sym);
      for (unsigned s : o.spread_seeds) {
        m.rotation_seed = s;
        add_one(m, Symmetry::none);
      }
    }
  // The reference size is also a table entry (default mesh, default tolerance), then the
  // reference sweeps at their own tolerance.
  add(MethodKind::discrete, o.reference_vertices, WlcExpansion::full, 0);
  for (unsigned s : o.reference_seeds)
    add_one({MethodKind::discrete, o.reference_vertices, WlcExpansion::full, s}, Symmetry::none,
            true);
  return out;
}

double max_relative_error(const CurvePoint& p, const ReferencePoint& r) {
  return std::max(std::abs(p.axial_um - r.axial_um) / r.axial_um,
                  std::abs(p.transverse_um - r.transverse_um) / r.transverse_um);
}

}  // namespace

AccuracyStudy assemble_accuracy_study(const AccuracyStudyOptions& o, std::vector<StudyRun> runs) {
  AccuracyStudy st;
  st.options = o;
  st.runs = std::move(runs);
  const size_t nf = o.forces_pN.size();
  // Reference: mean and spread of the full-level runs.
  std::vector<const StudyRun*> ref;
  for (const auto& r : st.runs)
    if (r.reference && r.run.method.kind == MethodKind::discrete &&
        r.run.method.resolution == o.reference_vertices && r.run.symmetry == Symmetry::none)
      ref.push_back(&r);
  if (ref.empty()) throw std::runtime_error("accuracy study: no reference run");
  for (const StudyRun* r : ref)
    if (!r->run.all_converged() || r->run.points.size() != nf)
      throw std::runtime_error("accuracy study: reference run " + r->run.method.name() +
                               " did not converge at every force");
  for (size_t k = 0; k < nf; ++k) {
    ReferencePoint p;
    p.force_pN = o.forces_pN[k];
    p.samples = static_cast<int>(ref.size());
    for (const StudyRun* r : ref) {
      p.axial_um += r->run.points[k].axial_um / p.samples;
      p.transverse_um += r->run.points[k].transverse_um / p.samples;
    }
    if (p.samples > 1) {
      for (const StudyRun* r : ref) {
        p.axial_sd_um += std::pow(r->run.points[k].axial_um - p.axial_um, 2);
        p.transverse_sd_um += std::pow(r->run.points[k].transverse_um - p.transverse_um, 2);
      }
      p.axial_sd_um = std::sqrt(p.axial_sd_um / (p.samples - 1));
      p.transverse_sd_um = std::sqrt(p.transverse_sd_um / (p.samples - 1));
    }
    st.reference_relative_sd = std::max({st.reference_relative_sd, p.axial_sd_um / p.axial_um,
                                         p.transverse_sd_um / p.transverse_um});
    st.reference.push_back(p);
  }
  st.reference_relative_se = st.reference_relative_sd / std::sqrt(static_cast<double>(ref.size()));
  // Rows: every method and resolution, errors worst over its rotations.
  for (const auto& s : st.runs) {
    const MethodRun& r = s.run;
    if (s.reference || r.method.rotation_seed != 0 || r.points.size() != nf) continue;
    AccuracyRow row;
    row.method = r.method;
    row.symmetry = r.symmetry;
    row.vertices = r.vertices;
    row.elements = r.elements;
    row.cpu_s = r.cpu_s;
    row.wall_s = r.total_s - r.setup_s;
    row.own_eg = r.eval_cpu_s > 0 ? r.cpu_s / r.eval_cpu_s : 0;
    row.cost_eg = s.unit_eval_cpu_s > 0 ? r.cpu_s / s.unit_eval_cpu_s : 0;
    std::vector<const MethodRun*> family;
    for (const auto& t : st.runs)  // the rotations, and this row's own default-mesh sweep
      if (!t.reference && same_family(t.run.method, r.method) && t.run.points.size() == nf &&
          (t.run.method.rotation_seed != 0 || t.run.symmetry == r.symmetry))
        family.push_back(&t.run);
    row.rotations = static_cast<int>(family.size());
    row.converged = std::all_of(family.begin(), family.end(),
                                [](const MethodRun* t) { return t->all_converged(); });
    row.error_by_force.assign(nf, 0.0);
    for (size_t k = 0; k < nf; ++k) {
      for (const MethodRun* t : family)
        row.error_by_force[k] =
            std::max(row.error_by_force[k], max_relative_error(t->points[k], st.reference[k]));
      row.error_default =
          std::max(row.error_default, max_relative_error(r.points[k], st.reference[k]));
      const double e = row.error_by_force[k];
      row.error_all = std::max(row.error_all, e);
      const double f = o.forces_pN[k];
      double& range = f < kLowForceLimit_pN    ? row.error_low
                      : f < kHighForceLimit_pN ? row.error_mid
                                               : row.error_high;
      range = std::max(range, e);
    }
    // Spread over the rotations of this method and resolution.
    if (family.size() > 1)
      for (size_t k = 0; k < nf; ++k) {
        double ma = 0, mt = 0, va = 0, vt = 0;
        const double n = static_cast<double>(family.size());
        for (auto* t : family)
          ma += t->points[k].axial_um / n, mt += t->points[k].transverse_um / n;
        for (auto* t : family)
          va += std::pow(t->points[k].axial_um - ma, 2),
              vt += std::pow(t->points[k].transverse_um - mt, 2);
        row.spread =
            std::max({row.spread, std::sqrt(va / (n - 1)) / ma, std::sqrt(vt / (n - 1)) / mt});
      }
    st.rows.push_back(std::move(row));
  }
  std::sort(st.rows.begin(), st.rows.end(), [](const AccuracyRow& a, const AccuracyRow& b) {
    if (a.method.kind != b.method.kind) return a.method.kind < b.method.kind;
    if (a.method.adapted != b.method.adapted) return b.method.adapted;
    if (a.method.refined != b.method.refined) return b.method.refined;
    if (a.method.loop != b.method.loop) return b.method.loop;
    if (a.method.size_ratio != b.method.size_ratio)
      return a.method.size_ratio < b.method.size_ratio;
    if (a.method.order != b.method.order)
      return order_code(a.method.order) > order_code(b.method.order);
    if (a.symmetry != b.symmetry) return a.symmetry < b.symmetry;
    return a.method.resolution < b.method.resolution;
  });
  // Richardson on the nested continuum chains (frequency doubling: elements x 4).
  for (WlcExpansion order : o.continuum_orders) {
    auto find = [&](int e) -> const MethodRun* {
      for (const auto& s : st.runs)
        if (s.run.method.kind == MethodKind::continuum && !s.run.method.adapted &&
            !s.run.method.refined && !s.run.method.loop && s.run.method.order == order &&
            s.run.method.resolution == e && s.run.method.rotation_seed == 0 &&
            s.run.symmetry == Symmetry::none && s.run.points.size() == nf && s.run.all_converged())
          return &s.run;
      return nullptr;
    };
    for (int e1 : o.continuum_elements) {
      const MethodRun *a = find(e1), *b = find(4 * e1), *c = find(16 * e1);
      if (!a || !b || !c) continue;
      for (size_t k = 0; k < nf; ++k) {
        ChainExtrapolation ch;
        ch.order = order;
        ch.elements[0] = e1, ch.elements[1] = 4 * e1, ch.elements[2] = 16 * e1;
        ch.force_pN = o.forces_pN[k];
        ch.axial =
            richardson_chain(a->points[k].axial_um, b->points[k].axial_um, c->points[k].axial_um);
        ch.transverse = richardson_chain(a->points[k].transverse_um, b->points[k].transverse_um,
                                         c->points[k].transverse_um);
        st.chains.push_back(ch);
      }
    }
  }
  // Richardson on the adapted chains e, 2e, 4e (h ratio sqrt 2), per seed.
  for (double ratio : o.adapted_size_ratios)
    for (WlcExpansion order : o.adapted_orders)
      for (int seed = 0; seed < o.adapted_seeds; ++seed) {
        auto find = [&](int e) -> const MethodRun* {
          for (const auto& s : st.runs)
            if (s.run.method.adapted && s.run.method.size_ratio == ratio &&
                s.run.method.order == order && s.run.method.resolution == e &&
                s.run.method.rotation_seed == static_cast<unsigned>(seed) &&
                s.run.points.size() == nf && s.run.all_converged())
              return &s.run;
          return nullptr;
        };
        for (int e1 : o.adapted_elements) {
          const MethodRun *a = find(e1), *b = find(2 * e1), *c = find(4 * e1);
          if (!a || !b || !c) continue;
          for (size_t k = 0; k < nf; ++k) {
            AdaptedChainExtrapolation ch;
            ch.order = order;
            ch.size_ratio = ratio;
            ch.seed = static_cast<unsigned>(seed);
            ch.elements[0] = e1, ch.elements[1] = 2 * e1, ch.elements[2] = 4 * e1;
            ch.force_pN = o.forces_pN[k];
            ch.axial = richardson_chain(a->points[k].axial_um, b->points[k].axial_um,
                                        c->points[k].axial_um, std::sqrt(2.0));
            ch.transverse = richardson_chain(a->points[k].transverse_um, b->points[k].transverse_um,
                                             c->points[k].transverse_um, std::sqrt(2.0));
            st.adapted_chains.push_back(ch);
          }
        }
      }
  return st;
}

std::vector<StudyRun> run_accuracy_sweeps(const AccuracyStudyOptions& o,
                                          const ProgressSink& progress) {
  o.validate();
  if (!o.cache_dir.empty()) ensure_output_directory(o.cache_dir);
  std::vector<StudyRun> runs;
  double unit_eval = 0;  // measured once per process, on first need
  for (const auto& [m, symmetry, reference] : study_methods(o)) {
    StudyRun s;
    const double tolerance_pN = reference ? o.reference_force_tolerance_pN : 0.0;
    if (!o.cache_dir.empty() &&
        read_cached_run(o.cache_dir, m, symmetry, tolerance_pN, o.forces_pN, s)) {
      runs.push_back(std::move(s));
      continue;
    }
    if (unit_eval == 0)
      unit_eval = network_evaluation_cpu_seconds(make_discrete_network(o.cost_unit_vertices));
    report(progress, "accuracy study: " + m.name() + ", symmetry " + to_string(symmetry) +
                         (reference ? ", reference (force tolerance " +
                                          format_tolerance(tolerance_pN) + " pN)"
                                    : ""));
    RunMethodOptions ro;
    ro.measure_evaluation = true;
    ro.symmetry = symmetry;
    ro.discrete_force_tolerance_pN = tolerance_pN;
    s.run = run_method(m, o.forces_pN, progress, ro);
    s.unit_eval_cpu_s = unit_eval;
    s.reference = reference;
    if (!o.cache_dir.empty()) write_cached_run(o.cache_dir, s, tolerance_pN);
    runs.push_back(std::move(s));
  }
  return runs;
}

AccuracyStudy run_accuracy_study(const AccuracyStudyOptions& o, const ProgressSink& progress) {
  return assemble_accuracy_study(o, run_accuracy_sweeps(o, progress));
}

namespace {

std::string series_name(const Method& m, Symmetry symmetry) {
  const std::string mirror = symmetry == Symmetry::mirror ? "_mirror" : "";
  if (m.kind == MethodKind::discrete) return "discrete" + mirror;
  const std::string law =
      m.order == WlcExpansion::full ? "continuum_full" : "continuum_p" + to_string(m.order);
  if (m.refined) return law + "_refined" + format_number(m.size_ratio) + mirror;
  if (m.loop) return law + "_loop" + mirror;
  return law + mirror;
}

/// Legend title of a series (plain words: gnuplot's enhanced text would subscript "_").
std::string series_title(const Method& m, Symmetry symmetry) {
  const std::string mirror = symmetry == Symmetry::mirror ? ", mirror" : "";
  if (m.kind == MethodKind::discrete) return "discrete" + mirror;
  const std::string law =
      m.order == WlcExpansion::full ? "continuum full law" : "continuum p = " + to_string(m.order);
  if (m.refined)  // "continuum" left out: the legend's columns must fit the figure's width
    return (m.size_ratio == 1.0 ? "on-surface icosphere"
                                : "refined mesh " + format_number(m.size_ratio)) +
           (m.order == WlcExpansion::full ? ", full law" : ", p = " + to_string(m.order)) + mirror;
  if (m.loop)
    return std::string("Loop element") +
           (m.order == WlcExpansion::full ? ", full law" : ", p = " + to_string(m.order)) + mirror;
  return law + mirror;
}

}  // namespace

namespace {

/// One row of accuracy_cost.csv (the columns of accuracy_cost_header()).
std::vector<double> accuracy_cost_row(const AccuracyStudy& st, const AccuracyRow& r) {
  const bool discrete = r.method.kind == MethodKind::discrete;
  return {discrete ? 0.0 : 1.0,
          discrete ? 0.0 : static_cast<double>(order_code(r.method.order)),
          static_cast<double>(r.method.resolution),
          static_cast<double>(r.vertices),
          static_cast<double>(r.elements),
          r.converged ? 1.0 : 0.0,
          r.error_all,
          r.error_low,
          r.error_mid,
          r.error_high,
          r.cost_eg,
          r.own_eg,
          r.cpu_s,
          r.wall_s,
          r.spread,
          static_cast<double>(r.rotations),
          r.error_default,
          st.reference_relative_sd,
          static_cast<double>(st.options.cost_unit_vertices),
          symmetry_code(r.symmetry)};
}

/// The adapted mesh's rows and sweeps (AccuracyStudyOptions::adapted_elements), beside the
/// table: the same columns as accuracy_cost.csv, accuracy_by_force.csv and convergence.csv
/// with the size ratio appended, their observed orders and their Richardson chains. With
/// `refined`, the refined mesh's (AccuracyStudyOptions::refined_elements) to the *_refined
/// files: convergence and observed orders from the full path only (the mirror path has the
/// same mesh), no Richardson chains (its sizes are not nested).
void write_adapted_rows(const AccuracyStudy& st, const std::vector<AccuracyRow>& rows,
                        const std::vector<const StudyRun*>& runs, const std::string& dir,
                        const std::string& refline, CostRows rows_kind = CostRows::adapted) {
  const auto& o = st.options;
  // The refined mesh and the Loop element are swept as the uniform meshes (rotations, both
  // solver paths); the adapted mesh over its seeds.
  const bool refined = rows_kind != CostRows::adapted;
  const std::string kind = rows_kind == CostRows::loop      ? "loop"
                           : rows_kind == CostRows::refined ? "refined"
                                                            : "adapted";
  const std::string what = rows_kind == CostRows::loop ? "Loop-element" : kind + "-mesh";
  const std::string mesh_line =
      rows_kind == CostRows::loop
          ? "continuum model on the C1 Loop element (rbc stretch --element loop; "
            "continuum/loop_stretch.hpp): the uniform icosphere of resolution = requested "
            "elements (--elements) with its vertices on the Evans-Fung surface, load and "
            "diameters on the limit surface; size_ratio 1 (a uniform mesh); rotations = the "
            "default orientation and the turned icospheres, as the table's; symmetry 0 full "
            "problem, 1 --symmetry mirror"
      : refined ? "continuum model on the refined mesh (rbc stretch --mesh refined --contact-load "
                  "exact-contact --measure quadric-fit; continuum/refined_mesh.hpp): resolution "
                  "= requested elements (--elements), size_ratio = --mesh-size-ratio; rotations = "
                  "the default orientation and the turned coarse icospheres (--mesh-seed), as the "
                  "table's; symmetry 0 full problem, 1 --symmetry mirror"
                : "continuum model on the adapted mesh (rbc stretch --mesh adapted --contact-load "
                  "exact-contact --measure quadric-fit; continuum/adapted_mesh.hpp): resolution = "
                  "requested elements (--elements), size_ratio = --mesh-size-ratio; rotations = "
                  "mesh seeds 0 .. rotations-1 (--mesh-seed: another triangulation of the same "
                  "size field, the analogue of the icosphere's rotations); full problem only "
                  "(symmetry 0)";
  CsvTable t;
  t.comments = {
      "accuracy against cost over the forces of the study (pN), " + what +
          " rows; the columns of accuracy_cost.csv and size_ratio",
      mesh_line, refline,
      "error = largest relative error of D_A and D_T against the reference (fraction, not %), "
      "worst over the " +
          std::string(refined ? "rotations" : "mesh seeds") + "; error_default = " +
          (refined ? "the default orientation's" : "seed 0's") + " alone, all forces",
      "cost_eg = process CPU of the whole sweep (mesh generation excluded, as the table's "
      "set-up) / CPU of one energy+gradient evaluation of the discrete network with " +
          std::to_string(o.cost_unit_vertices) + " requested vertices, in the same process"};
  t.header = accuracy_cost_header();
  t.header.push_back("size_ratio");
  CsvTable bf;
  bf.comments = {"per-force relative errors of accuracy_cost_" + kind + ".csv's rows (same order)",
                 mesh_line, refline};
  bf.header = {"kind",     "order", "resolution",   "converged", "cost_eg",
               "force_pN", "error", "reference_se", "symmetry",  "size_ratio"};
  for (const auto& r : rows) {
    const double order = static_cast<double>(order_code(r.method.order));
    t.rows.push_back(accuracy_cost_row(st, r));
    t.rows.back().push_back(r.method.size_ratio);
    for (size_t k = 0; k < r.error_by_force.size(); ++k)
      bf.rows.push_back({1.0, order, static_cast<double>(r.method.resolution),
                         r.converged ? 1.0 : 0.0, r.cost_eg, o.forces_pN[k], r.error_by_force[k],
                         st.reference_relative_se, symmetry_code(r.symmetry), r.method.size_ratio});
  }
  write_csv(dir + "/accuracy_cost_" + kind + ".csv", t);
  write_csv(dir + "/accuracy_by_force_" + kind + ".csv", bf);
  CsvTable cv;
  cv.comments = {"every " + what + " sweep" + (refined ? " on the full path" : "") +
                     ": diameters (um) per force, rest surface area (um^2)",
                 mesh_line,
                 "order: 0 full law, 2, 3, 4; seed: --mesh-seed; setup_s: mesh generation and "
                 "model set-up (s, wall)"};
  cv.header = {"order",    "size_ratio", "resolution",    "seed",      "vertices",    "elements",
               "force_pN", "axial_um",   "transverse_um", "converged", "surface_um2", "setup_s"};
  for (const StudyRun* s : runs) {
    const MethodRun& r = s->run;
    if (refined && r.symmetry != Symmetry::none) continue;
    for (const auto& p : r.points)
      cv.rows.push_back(
          {static_cast<double>(order_code(r.method.order)), r.method.size_ratio,
           static_cast<double>(r.method.resolution), static_cast<double>(r.method.rotation_seed),
           static_cast<double>(r.vertices), static_cast<double>(r.elements), p.force_pN, p.axial_um,
           p.transverse_um, p.converged ? 1.0 : 0.0, r.surface_um2, r.setup_s});
  }
  write_csv(dir + "/convergence_" + kind + ".csv", cv);
  // Observed order per law and size ratio, as orders.csv (errors above twice the reference sd).
  CsvTable oc;
  oc.comments = {
      "observed order p of error ~ h^p (h ~ N^-1/2, N vertices) of the " + kind + " rows" +
      (refined ? " (full path)" : "") +
      ", least squares over the rows with error_all > 2 x reference sd; order 0 full, 2, 3, 4"};
  oc.header = {"order",         "size_ratio", "points", "smallest_vertices", "largest_vertices",
               "observed_order"};
  std::map<std::pair<int, double>, std::pair<std::vector<double>, std::vector<double>>> fits;
  for (const auto& r : rows)
    if (r.converged && r.error_all > 2 * st.reference_relative_sd && r.symmetry == Symmetry::none) {
      auto& f = fits[{order_code(r.method.order), r.method.size_ratio}];
      f.first.push_back(r.vertices);
      f.second.push_back(r.error_all);
    }
  for (const auto& [key, f] : fits)
    oc.rows.push_back(
        {static_cast<double>(key.first), key.second, static_cast<double>(f.first.size()),
         *std::min_element(f.first.begin(), f.first.end()),
         *std::max_element(f.first.begin(), f.first.end()), observed_order(f.first, f.second)});
  write_csv(dir + "/orders_" + kind + ".csv", oc);
  if (refined) return;
  CsvTable rc;
  rc.comments = {
      "Richardson extrapolation of the adapted chains (requested elements e, 2e, 4e: "
      "h ratio sqrt 2), per mesh seed and force",
      "order: 0 full law, 2, 3, 4; clean = same-sign differences and observed order "
      "in [0.5, 4]; limit = finest value when not clean"};
  rc.header = {"order",
               "size_ratio",
               "seed",
               "e1",
               "e2",
               "e3",
               "force_pN",
               "axial_limit_um",
               "axial_order",
               "axial_clean",
               "transverse_limit_um",
               "transverse_order",
               "transverse_clean"};
  for (const auto& c : st.adapted_chains)
    rc.rows.push_back({static_cast<double>(order_code(c.order)), c.size_ratio,
                       static_cast<double>(c.seed), static_cast<double>(c.elements[0]),
                       static_cast<double>(c.elements[1]), static_cast<double>(c.elements[2]),
                       c.force_pN, c.axial.limit, c.axial.order, c.axial.clean ? 1.0 : 0.0,
                       c.transverse.limit, c.transverse.order, c.transverse.clean ? 1.0 : 0.0});
  write_csv(dir + "/richardson_adapted.csv", rc);
}

}  // namespace

void write_accuracy_study(const AccuracyStudy& st, const std::string& dir) {
  ensure_output_directory(dir);
  const auto& o = st.options;
  // The table's own files hold the uniform meshes' rows and sweeps; the adapted ones go to
  // the *_adapted files (write_adapted_rows).
  // The refined ones to the *_refined files.
  // The Loop element's to the *_loop files.
  std::vector<AccuracyRow> table_rows, adapted_rows, refined_rows, loop_rows;
  for (const auto& r : st.rows)
    (r.method.adapted   ? adapted_rows
     : r.method.refined ? refined_rows
     : r.method.loop    ? loop_rows
                        : table_rows)
        .push_back(r);
  std::vector<const StudyRun*> table_runs, adapted_runs, refined_runs, loop_runs;
  for (const auto& s : st.runs)
    (s.run.method.adapted   ? adapted_runs
     : s.run.method.refined ? refined_runs
     : s.run.method.loop    ? loop_runs
                            : table_runs)
        .push_back(&s);
  std::ostringstream refline;
  refline << "reference: discrete network at the full spectrin level (" << o.reference_vertices
          << " requested vertices), mean over " << o.reference_seeds.size()
          << " triangulation rotations, force tolerance " << o.reference_force_tolerance_pN
          << " pN; largest relative sd " << st.reference_relative_sd
          << ", relative standard error of the mean " << st.reference_relative_se;
  // accuracy_cost.csv: one row per method and resolution.
  CsvTable t;
  t.comments = {
      "accuracy against cost over the forces of the study (pN): Mills et al. 2004",
      refline.str(),
      "error = largest relative error of D_A and D_T against the reference (fraction, not %), "
      "worst over the row's triangulation rotations (column rotations; the default mesh "
      "included); error_default = the default mesh's alone, all forces",
      "error_low: F < 50 pN; error_mid: 50 <= F < 120 pN; error_high: F >= 120 pN",
      "cost_eg = process CPU of the whole sweep / CPU of one energy+gradient evaluation of the "
      "discrete network with " +
          std::to_string(o.cost_unit_vertices) +
          " requested vertices, measured in the same process (machine-independent unit)",
      "own_eg = the same in evaluations of the method's own model at its size (rbc bench's "
      "eg_evals); cpu_s, wall_s for information (1 thread, shared machine)",
      "spread = largest relative sd of D_A, D_T over triangulation rotations (0 = not measured)",
      "kind: 0 discrete, 1 continuum; order: 0 full law, 2, 3, 4 (continuum); converged 0/1",
      "symmetry: the solver path of cost_eg, 0 full problem, 1 --symmetry mirror (same mesh: "
      "the errors are those of the full problem's row to the solver tolerance)"};
  t.header = accuracy_cost_header();
  for (const auto& r : table_rows) t.rows.push_back(accuracy_cost_row(st, r));
  write_csv(dir + "/accuracy_cost.csv", t);
  // accuracy_by_force.csv: the per-force errors the --accuracy choice reads.
  CsvTable bf;
  bf.comments = {"per-force relative errors of accuracy_cost.csv's rows (same order)",
                 refline.str(),
                 "kind: 0 discrete, 1 continuum; order: 0 full law, 2, 3, 4; error = max of the "
                 "relative errors of D_A and D_T (fraction); cost_eg as in accuracy_cost.csv",
                 "reference_se = relative standard error of the reference mean (fraction)",
                 "symmetry: solver path of cost_eg, 0 full problem, 1 --symmetry mirror"};
  bf.header = {"kind",     "order", "resolution",   "converged", "cost_eg",
               "force_pN", "error", "reference_se", "symmetry"};
  for (const auto& r : table_rows)
    for (size_t k = 0; k < r.error_by_force.size(); ++k)
      bf.rows.push_back({r.method.kind == MethodKind::discrete ? 0.0 : 1.0,
                         r.method.kind == MethodKind::discrete
                             ? 0.0
                             : static_cast<double>(order_code(r.method.order)),
                         static_cast<double>(r.method.resolution), r.converged ? 1.0 : 0.0,
                         r.cost_eg, o.forces_pN[k], r.error_by_force[k], st.reference_relative_se,
                         symmetry_code(r.symmetry)});
  write_csv(dir + "/accuracy_by_force.csv", bf);
  // reference.csv
  CsvTable rf;
  rf.comments = {refline.str(), "sd = sample standard deviation over the rotations (um)"};
  rf.header = {"force_pN",      "axial_um",         "axial_sd_um",
               "transverse_um", "transverse_sd_um", "samples"};
  for (const auto& p : st.reference)
    rf.rows.push_back({p.force_pN, p.axial_um, p.axial_sd_um, p.transverse_um, p.transverse_sd_um,
                       static_cast<double>(p.samples)});
  write_csv(dir + "/reference.csv", rf);
  // convergence.csv: every run (all rotations), with its bead patches.
  CsvTable cv;
  cv.comments = {"every sweep of the study: diameters (um) per force, bead patch areas (um^2)",
                 "kind: 0 discrete, 1 continuum; order: 0 full law, 2, 3, 4; seed: rotation; "
                 "symmetry: 0 full problem, 1 --symmetry mirror; reference: 1 for the reference "
                 "sweeps (at the reference force tolerance), 0 for the table's (default)"};
  cv.header = {"kind",        "order",          "resolution",      "seed",          "vertices",
               "elements",    "force_pN",       "axial_um",        "transverse_um", "converged",
               "surface_um2", "patch_plus_um2", "patch_minus_um2", "symmetry",      "reference"};
  for (const StudyRun* sp : table_runs) {
    const StudyRun& s = *sp;
    const MethodRun& r = s.run;
    for (const auto& p : r.points)
      cv.rows.push_back(
          {r.method.kind == MethodKind::discrete ? 0.0 : 1.0,
           r.method.kind == MethodKind::discrete ? 0.0
                                                 : static_cast<double>(order_code(r.method.order)),
           static_cast<double>(r.method.resolution), static_cast<double>(r.method.rotation_seed),
           static_cast<double>(r.vertices), static_cast<double>(r.elements), p.force_pN, p.axial_um,
           p.transverse_um, p.converged ? 1.0 : 0.0, r.surface_um2, r.patch_plus_um2,
           r.patch_minus_um2, symmetry_code(r.symmetry), s.reference ? 1.0 : 0.0});
  }
  write_csv(dir + "/convergence.csv", cv);
  // richardson.csv
  CsvTable rc;
  rc.comments = {
      "Richardson extrapolation of nested continuum chains (elements e, 4e, 16e: "
      "icosphere frequency f, 2f, 4f), per force",
      "order: 0 full law, 2, 3, 4; clean = same-sign differences and observed order "
      "in [0.5, 4]; limit = finest value when not clean"};
  rc.header = {"order",
               "e1",
               "e2",
               "e3",
               "force_pN",
               "axial_limit_um",
               "axial_order",
               "axial_clean",
               "transverse_limit_um",
               "transverse_order",
               "transverse_clean"};
  for (const auto& c : st.chains)
    rc.rows.push_back({static_cast<double>(order_code(c.order)), static_cast<double>(c.elements[0]),
                       static_cast<double>(c.elements[1]), static_cast<double>(c.elements[2]),
                       c.force_pN, c.axial.limit, c.axial.order, c.axial.clean ? 1.0 : 0.0,
                       c.transverse.limit, c.transverse.order, c.transverse.clean ? 1.0 : 0.0});
  write_csv(dir + "/richardson.csv", rc);
  // orders.csv: observed order of each model's error against resolution, over the sizes
  // whose error exceeds twice the reference spread (smaller errors are not resolved).
  CsvTable oc;
  oc.comments = {
      "observed order p of error ~ h^p (h ~ N^-1/2), least squares over the rows "
      "with error_all > 2 x reference sd; kind 0 discrete, 1 continuum; order 0 "
      "full, 2",
      "points = rows used; smallest/largest = their vertex range"};
  oc.header = {"kind",          "order", "points", "smallest_vertices", "largest_vertices",
               "observed_order"};
  std::map<std::pair<int, int>, std::pair<std::vector<double>, std::vector<double>>> fits;
  for (const auto& r : table_rows)
    if (r.converged && r.symmetry == Symmetry::none && r.error_all > 2 * st.reference_relative_sd &&
        !(r.method.kind == MethodKind::discrete && r.method.resolution == o.reference_vertices)) {
      auto& f = fits[{r.method.kind == MethodKind::discrete ? 0 : 1,
                      r.method.kind == MethodKind::discrete ? 0 : order_code(r.method.order)}];
      f.first.push_back(r.vertices);
      f.second.push_back(r.error_all);
    }
  for (const auto& [key, f] : fits)
    oc.rows.push_back(
        {static_cast<double>(key.first), static_cast<double>(key.second),
         static_cast<double>(f.first.size()), *std::min_element(f.first.begin(), f.first.end()),
         *std::max_element(f.first.begin(), f.first.end()), observed_order(f.first, f.second)});
  write_csv(dir + "/orders.csv", oc);
  // Plots: error against cost, and error against resolution.
  // Series by model and solver path; the resolution plot shows the full problem's rows only
  // (a mirror row has the same errors).
  std::map<std::string, std::vector<const AccuracyRow*>> series;
  for (const auto& r : table_rows)
    if (r.converged) series[series_name(r.method, r.symmetry)].push_back(&r);
  // The refined rows of size ratio 1 (the icosphere with its vertices on the surface, the exact
  // contact load and the quadric-fit diameters): the continuum model at its best.
  for (const auto& r : refined_rows)
    if (r.converged && r.method.size_ratio == 1.0)
      series[series_name(r.method, r.symmetry)].push_back(&r);
  // The Loop element's rows: the C1 element on the uniform meshes.
  for (const auto& r : loop_rows)
    if (r.converged) series[series_name(r.method, r.symmetry)].push_back(&r);
  for (const bool by_cost : {true, false}) {
    PlotSpec spec;
    spec.title = by_cost ? "Accuracy against cost, 13 forces of 0-193 pN"
                         : "Error against resolution, 13 forces of 0-193 pN";
    spec.xlabel = by_cost ? "cost (energy+gradient evaluations of the N = 1,002 network)"
                          : "mesh vertices (network: junction complexes; continuum: element "
                            "corners)";
    spec.ylabel = "largest relative error of D_{A}, D_{T} (%)";
    spec.log_x = spec.log_y = true;
    spec.y_range = "[1e-2:10]";  // percent
    spec.width_px = 1400;        // four legend entries a row
    {
      std::ostringstream line;  // the reference's own spread: errors below it are not resolved
      line << "set arrow from graph 0, first " << 100 * st.reference_relative_sd
           << " to graph 1, first " << 100 * st.reference_relative_sd
           << " nohead dt 2 lc rgb '#777777'";
      spec.extra_commands.push_back(line.str());
      std::ostringstream label;
      label << "set label 'reference spread (sd over rotations)' at graph 0.02, first "
            << 115 * st.reference_relative_sd << " tc rgb '#777777'";
      spec.extra_commands.push_back(label.str());
    }
    for (const auto& [name, rows] : series) {
      const bool mirror = rows.front()->symmetry == Symmetry::mirror;
      if (!by_cost && mirror) continue;
      // A model's colour, shared by its mirror path.
      const std::string model = series_name(rows.front()->method, Symmetry::none);
      const char* colour = model == "continuum_full"      ? "#1f77b4"
                           : model == "continuum_p2"      ? "#2ca02c"
                           : model == "discrete"          ? "#ff7f0e"
                           : rows.front()->method.refined ? "#d62728"
                           : rows.front()->method.loop    ? "#8c564b"
                                                          : "#9467bd";
      const std::string title = series_title(rows.front()->method, rows.front()->symmetry);
      CsvTable s;
      s.header = {"x", "error", "spread"};
      for (auto* r : rows)
        s.rows.push_back({by_cost ? r->cost_eg : static_cast<double>(r->vertices),
                          std::max(r->error_all, 1e-6), std::max(r->spread, 1e-6)});
      std::sort(s.rows.begin(), s.rows.end());
      const std::string file = (by_cost ? "cost_" : "resolution_") + name + ".csv";
      write_csv(dir + "/" + file, s);
      // The mirror path of a model: its colour, open symbols, dashed.
      spec.series.push_back(
          {title, file, "1:($2*100)", "linespoints", colour, mirror ? 6 : 7, mirror ? 2 : 1});
      CsvTable sp;  // rotation spread, only the sizes that were rotated
      sp.header = s.header;
      for (const auto& q : s.rows)
        if (q[2] > 1e-6) sp.rows.push_back(q);
      if (!by_cost && !sp.rows.empty()) {
        write_csv(dir + "/spread_" + name + ".csv", sp);
        spec.series.push_back({title + " rotation spread (sd)", "spread_" + name + ".csv",
                               "1:($3*100)", "linespoints", colour, 6, 2});
      }
    }
    render_plot(spec, dir, by_cost ? "accuracy_cost" : "accuracy_resolution");
  }
  if (!adapted_rows.empty()) write_adapted_rows(st, adapted_rows, adapted_runs, dir, refline.str());
  if (!refined_rows.empty())
    write_adapted_rows(st, refined_rows, refined_runs, dir, refline.str(), CostRows::refined);
  if (!loop_rows.empty())
    write_adapted_rows(st, loop_rows, loop_runs, dir, refline.str(), CostRows::loop);
}

AccuracyCostTable load_accuracy_cost(const std::string& path, CostRows kind) {
  const CsvTable t = read_csv(path);
  // The last column (symmetry) came with the mirror rows; a table without it is all full. The
  // graded-mesh files always have it, and size_ratio after it.
  const std::vector<std::string>& full_header = accuracy_cost_header();
  const std::vector<std::string> older(full_header.begin(), full_header.end() - 1);
  std::vector<std::string> graded = full_header;
  graded.push_back("size_ratio");
  const bool beside = kind != CostRows::table;
  const bool has_symmetry = t.header == (beside ? graded : full_header);
  if (!has_symmetry && (beside || t.header != older))
    throw std::runtime_error(path + ": not an accuracy_cost" +
                             (kind == CostRows::adapted   ? "_adapted"
                              : kind == CostRows::refined ? "_refined"
                              : kind == CostRows::loop    ? "_loop"
                                                          : "") +
                             ".csv (header differs)");
  const size_t columns = t.header.size();
  AccuracyCostTable out;
  for (size_t k = 0; k < t.rows.size(); ++k) {
    const auto& q = t.rows[k];
    if (q.size() != columns)
      throw std::runtime_error(path + " row " + std::to_string(k + 1) + ": wrong column count");
    if (has_symmetry && q[19] != 0 && q[19] != 1)
      throw std::runtime_error(path + " row " + std::to_string(k + 1) +
                               ": symmetry must be 0 (none) or 1 (mirror), got " +
                               std::to_string(q[19]));
    AccuracyRow r;
    r.method.kind = q[0] == 0 ? MethodKind::discrete : MethodKind::continuum;
    r.method.order = q[1] == 2   ? WlcExpansion::order2
                     : q[1] == 3 ? WlcExpansion::order3
                     : q[1] == 4 ? WlcExpansion::order4
                                 : WlcExpansion::full;
    r.method.resolution = static_cast<int>(q[2]);
    r.vertices = static_cast<int>(q[3]);
    r.elements = static_cast<int>(q[4]);
    r.converged = q[5] != 0;
    r.error_all = q[6], r.error_low = q[7], r.error_mid = q[8], r.error_high = q[9];
    r.cost_eg = q[10], r.own_eg = q[11], r.cpu_s = q[12], r.wall_s = q[13], r.spread = q[14];
    r.rotations = static_cast<int>(q[15]);
    r.error_default = q[16];
    out.reference_relative_sd = q[17];
    out.cost_unit_vertices = static_cast<int>(q[18]);
    r.symmetry = has_symmetry && q[19] == 1 ? Symmetry::mirror : Symmetry::none;
    if (beside) {
      if (r.method.kind != MethodKind::continuum || !(q[20] >= 1 && q[20] <= 10))
        throw std::runtime_error(path + " row " + std::to_string(k + 1) +
                                 ": a graded-mesh row must be a continuum row with a size ratio "
                                 "in [1, 10], got kind " +
                                 std::to_string(q[0]) + ", size ratio " + std::to_string(q[20]));
      r.method.adapted = kind == CostRows::adapted;
      r.method.refined = kind == CostRows::refined;
      r.method.loop = kind == CostRows::loop;
      r.method.size_ratio = q[20];
    }
    out.rows.push_back(r);
  }
  if (out.rows.empty()) throw std::runtime_error(path + ": no rows");
  return out;
}

std::string accuracy_verdict(const std::vector<AccuracyRow>& rows, double reference_relative_sd,
                             int cost_unit_vertices) {
  std::ostringstream out;
  out.precision(3);
  const double levels[] = {0.005, 0.01, 0.02, 0.05};
  struct Range {
    const char* name;
    double AccuracyRow::*error;
  };
  const Range ranges[] = {{"all 13 forces (0-193 pN)", &AccuracyRow::error_all},
                          {"F < 50 pN", &AccuracyRow::error_low},
                          {"50 <= F < 120 pN", &AccuracyRow::error_mid},
                          {"F >= 120 pN", &AccuracyRow::error_high}};
  out << "Is the continuum model cheaper at equal accuracy? Cheapest method of each model "
         "whose largest relative error of D_A and D_T (worst over the triangulation "
         "rotations) meets the level; cost in energy+gradient evaluations of the N ~ "
      << cost_unit_vertices << " network; reference spread " << 100 * reference_relative_sd
      << " % (sd over rotations).\n\n";
  for (const auto& range : ranges) {
    out << "- " << range.name << ":";
    int continuum_wins = 0, discrete_wins = 0, ties = 0;
    for (double level : levels) {
      const AccuracyRow *d = nullptr, *c = nullptr;
      for (const auto& r : rows) {
        if (!r.converged || r.*(range.error) > level) continue;
        const AccuracyRow*& best = r.method.kind == MethodKind::discrete ? d : c;
        if (!best || r.cost_eg < best->cost_eg) best = &r;
      }
      out << " " << 100 * level << " %: ";
      if (!d && !c) {
        out << "neither reaches it;";
      } else if (d && c) {
        const bool cont = c->cost_eg < d->cost_eg;
        const double ratio = std::max(c->cost_eg, d->cost_eg) / std::min(c->cost_eg, d->cost_eg);
        const AccuracyRow *win = cont ? c : d, *lose = cont ? d : c;
        if (ratio < kAccuracyCostTieRatio) {
          ++ties;
          out << "tie, " << method_spec(c->method, c->symmetry) << " (" << std::lround(c->cost_eg)
              << ") vs " << method_spec(d->method, d->symmetry) << " (" << std::lround(d->cost_eg)
              << ");";
        } else {
          (cont ? continuum_wins : discrete_wins)++;
          out << method_spec(win->method, win->symmetry) << " (" << std::lround(win->cost_eg)
              << ") is " << ratio << "x cheaper than " << method_spec(lose->method, lose->symmetry)
              << " (" << std::lround(lose->cost_eg) << ");";
        }
      } else {
        (c ? continuum_wins : discrete_wins)++;
        const AccuracyRow* only = d ? d : c;
        out << "only " << (c ? "continuum " : "discrete ")
            << method_spec(only->method, only->symmetry) << " (" << std::lround(only->cost_eg)
            << ");";
      }
    }
    out << " -> continuum cheaper at " << continuum_wins << ", discrete at " << discrete_wins
        << ", tie at " << ties << " of 4 levels\n";
  }
  out << "(tie: costs within a factor " << kAccuracyCostTieRatio
      << ", the reproducibility of a CPU-time cost on a shared machine)\n";
  return out.str();
}

std::string accuracy_study_verdict(const AccuracyStudy& st) {
  return accuracy_verdict(st.rows, st.reference_relative_sd, st.options.cost_unit_vertices);
}

}  // namespace rbc
