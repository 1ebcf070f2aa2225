// SPDX-License-Identifier: GPL-3.0-or-later
// The accuracy-cost study end to end on tiny sizes: run_accuracy_study's table recomputed in
// the test from its own sweeps (reference = mean over the reference rotations; a row's error =
// largest relative error of D_A and D_T, worst over its rotations, max over forces and per
// force range; cost = sweep CPU / cost-unit evaluation CPU), the files write_accuracy_study
// leaves (accuracy_cost.csv and the accuracy_by_force.csv `rbc stretch --accuracy` reads)
// parsed back to the same numbers, and accuracy_study_verdict naming, per force range and
// level, the cheapest converged row of each model meeting it.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "compare/accuracy_choice.hpp"
#include "compare/accuracy_study.hpp"
#include "test_output.hpp"

namespace rbc {
namespace accuracy_study_test {
namespace {

/// A row's identity: kind, continuum order (the discrete model: full), resolution, solver path.
using RowKey = std::tuple<MethodKind, WlcExpansion, int, Symmetry>;

RowKey key_of(const Method& m, Symmetry symmetry) {
  return {m.kind, m.kind == MethodKind::discrete ? WlcExpansion::full : m.order, m.resolution,
          symmetry};
}

/// What the test expects of one table row, computed here from the sweeps.
struct ExpectedRow {
  Method method;
  Symmetry symmetry = Symmetry::none;
  int vertices = 0, elements = 0, rotations = 0;
  bool converged = true;
  std::vector<double> error_by_force;
  double error_all = 0, error_low = 0, error_mid = 0, error_high = 0, error_default = 0;
  double cost_eg = 0, spread = 0;
};

/// A CSV file as written by the library: '#' comment lines, a header, numeric rows. Parsed
/// here with the standard library alone.
struct PlainCsv {
  std::vector<std::string> header;
  std::vector<std::vector<double>> rows;
  size_t column(const std::string& name) const {
    const auto it = std::find(header.begin(), header.end(), name);
    if (it == header.end()) throw std::runtime_error("no column " + name);
    return static_cast<size_t>(it - header.begin());
  }
};

PlainCsv read_plain_csv(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open " + path);
  PlainCsv t;
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::stringstream ss(line);
    std::vector<std::string> cells;
    for (std::string c; std::getline(ss, c, ',');) cells.push_back(c);
    if (t.header.empty()) {
      t.header = cells;
      continue;
    }
    std::vector<double> row;
    for (const auto& c : cells) row.push_back(std::stod(c));
    t.rows.push_back(row);
  }
  return t;
}

/// Values written with 10 significant digits read back to within 5e-10 relative.
void expect_written(double written, double value, const std::string& what) {
  EXPECT_LE(std::abs(written - value), 1e-9 * std::abs(value) + 1e-300) << what;
}

/// The study's force ranges (pN): low < 50 <= mid < 120 <= high (the AccuracyRow columns).
enum class Range { all, low, mid, high };
Range range_of(double force_pN) {
  return force_pN < 50 ? Range::low : force_pN < 120 ? Range::mid : Range::high;
}

double error_in(const ExpectedRow& r, Range range) {
  switch (range) {
    case Range::low:
      return r.error_low;
    case Range::mid:
      return r.error_mid;
    case Range::high:
      return r.error_high;
    default:
      return r.error_all;
  }
}

TEST(AccuracyStudyEndToEnd, TableFilesAndVerdictFollowFromTheSweeps) {
  const std::filesystem::path dir =
      rbc::testing::fresh_output_dir("AccuracyStudyEndToEnd_TableFilesAndVerdict");
  AccuracyStudyOptions o;
  o.forces_pN = {0, 30, 80, 150};  // two forces in the low range, one in each of the others
  o.discrete_vertices = {150};
  o.continuum_elements = {300};
  o.continuum_orders = {WlcExpansion::order2};
  o.reference_vertices = 300;
  o.reference_seeds = {0, 1};
  o.spread_seeds = {1};
  o.spread_max_resolution = 300;
  o.symmetries = {Symmetry::none, Symmetry::mirror};
  o.cost_unit_vertices = 150;
  const AccuracyStudy st = run_accuracy_study(o, {});
  const size_t nf = o.forces_pN.size();

  // The sweeps the options ask for: each table size on the default mesh, once per solver
  // path, and once rotated (full path); the reference size's table sweep likewise; the two
  // reference sweeps (full path).
  std::map<std::tuple<RowKey, unsigned, bool>, int> swept;
  for (const StudyRun& s : st.runs) {
    ++swept[{key_of(s.run.method, s.run.symmetry), s.run.method.rotation_seed, s.reference}];
    ASSERT_EQ(s.run.points.size(), nf) << s.run.method.name();
    EXPECT_GT(s.run.cpu_s, 0) << s.run.method.name();
    EXPECT_GT(s.unit_eval_cpu_s, 0) << s.run.method.name();
  }
  std::map<std::tuple<RowKey, unsigned, bool>, int> asked;
  const Method d150{MethodKind::discrete, 150, WlcExpansion::full},
      c300{MethodKind::continuum, 300, WlcExpansion::order2},
      d300{MethodKind::discrete, 300, WlcExpansion::full};
  for (const Method& m : {d150, c300, d300})
    for (Symmetry s : {Symmetry::none, Symmetry::mirror}) asked[{key_of(m, s), 0u, false}] = 1;
  asked[{key_of(d150, Symmetry::none), 1u, false}] = 1;
  asked[{key_of(c300, Symmetry::none), 1u, false}] = 1;
  asked[{key_of(d300, Symmetry::none), 0u, true}] = 1;
  asked[{key_of(d300, Symmetry::none), 1u, true}] = 1;
  EXPECT_EQ(swept, asked);

  // The reference: per force, mean and sample sd over the reference sweeps.
  std::vector<const MethodRun*> refs;
  for (const StudyRun& s : st.runs)
    if (s.reference) refs.push_back(&s.run);
  ASSERT_EQ(refs.size(), 2u);
  std::vector<double> ref_a(nf), ref_t(nf);
  double ref_sd = 0;
  for (size_t k = 0; k < nf; ++k) {
    const double a0 = refs[0]->points[k].axial_um, a1 = refs[1]->points[k].axial_um;
    const double t0 = refs[0]->points[k].transverse_um, t1 = refs[1]->points[k].transverse_um;
    ref_a[k] = (a0 + a1) / 2, ref_t[k] = (t0 + t1) / 2;
    // Two samples: sd = |x0 - x1| / sqrt(2).
    ref_sd = std::max({ref_sd, std::abs(a0 - a1) / std::sqrt(2.0) / ref_a[k],
                       std::abs(t0 - t1) / std::sqrt(2.0) / ref_t[k]});
    EXPECT_NEAR(st.reference[k].axial_um, ref_a[k], 1e-12 * ref_a[k]);
    EXPECT_NEAR(st.reference[k].transverse_um, ref_t[k], 1e-12 * ref_t[k]);
  }
  EXPECT_NEAR(st.reference_relative_sd, ref_sd, 1e-9 * ref_sd + 1e-15);

  // Every table row, from the sweeps: a default-mesh table sweep and the rotations of its size.
  auto relative_error = [&](const CurvePoint& p, size_t k) {
    return std::max(std::abs(p.axial_um - ref_a[k]) / ref_a[k],
                    std::abs(p.transverse_um - ref_t[k]) / ref_t[k]);
  };
  std::map<RowKey, ExpectedRow> expected;
  for (const StudyRun& s : st.runs) {
    if (s.reference || s.run.method.rotation_seed != 0) continue;
    ExpectedRow e;
    e.method = s.run.method;
    e.symmetry = s.run.symmetry;
    e.vertices = s.run.vertices;
    e.elements = s.run.elements;
    e.cost_eg = s.run.cpu_s / s.unit_eval_cpu_s;
    std::vector<const MethodRun*> family = {&s.run};
    for (const StudyRun& t : st.runs)
      if (!t.reference && t.run.method.rotation_seed != 0 &&
          key_of(t.run.method, Symmetry::none) == key_of(s.run.method, Symmetry::none))
        family.push_back(&t.run);
    e.rotations = static_cast<int>(family.size());
    e.error_by_force.assign(nf, 0.0);
    for (size_t k = 0; k < nf; ++k) {
      double ma = 0, mt = 0;
      for (const MethodRun* t : family) {
        e.converged = e.converged && t->points[k].converged;
        e.error_by_force[k] = std::max(e.error_by_force[k], relative_error(t->points[k], k));
        ma += t->points[k].axial_um / family.size(),
            mt += t->points[k].transverse_um / family.size();
      }
      double va = 0, vt = 0;
      for (const MethodRun* t : family)
        va += std::pow(t->points[k].axial_um - ma, 2),
            vt += std::pow(t->points[k].transverse_um - mt, 2);
      if (family.size() > 1)
        e.spread = std::max({e.spread, std::sqrt(va / (family.size() - 1)) / ma,
                             std::sqrt(vt / (family.size() - 1)) / mt});
      e.error_default = std::max(e.error_default, relative_error(s.run.points[k], k));
      e.error_all = std::max(e.error_all, e.error_by_force[k]);
      const Range r = range_of(o.forces_pN[k]);
      double& in_range = r == Range::low   ? e.error_low
                         : r == Range::mid ? e.error_mid
                                           : e.error_high;
      in_range = std::max(in_range, e.error_by_force[k]);
    }
    expected[key_of(e.method, e.symmetry)] = e;
  }
  ASSERT_EQ(expected.size(), 6u);  // 3 discretisations x 2 solver paths

  // The table in memory.
  ASSERT_EQ(st.rows.size(), expected.size());
  for (const AccuracyRow& r : st.rows) {
    const auto it = expected.find(key_of(r.method, r.symmetry));
    ASSERT_NE(it, expected.end()) << r.method.name();
    const ExpectedRow& e = it->second;
    const std::string what = method_spec(r.method, r.symmetry);
    EXPECT_EQ(r.rotations, e.rotations) << what;
    EXPECT_EQ(r.converged, e.converged) << what;
    ASSERT_EQ(r.error_by_force.size(), nf) << what;
    for (size_t k = 0; k < nf; ++k)
      EXPECT_NEAR(r.error_by_force[k], e.error_by_force[k], 1e-12) << what << " force " << k;
    EXPECT_NEAR(r.error_all, e.error_all, 1e-12) << what;
    EXPECT_NEAR(r.error_low, e.error_low, 1e-12) << what;
    EXPECT_NEAR(r.error_mid, e.error_mid, 1e-12) << what;
    EXPECT_NEAR(r.error_high, e.error_high, 1e-12) << what;
    EXPECT_NEAR(r.error_default, e.error_default, 1e-12) << what;
    EXPECT_NEAR(r.spread, e.spread, 1e-12) << what;
    EXPECT_NEAR(r.cost_eg, e.cost_eg, 1e-12 * e.cost_eg) << what;
  }
  // The rotated size has a rotation behind its errors; the reference size's table sweep has
  // none (the reference sweeps are not its rotations).
  EXPECT_EQ(expected.at(key_of(d150, Symmetry::none)).rotations, 2);
  EXPECT_EQ(expected.at(key_of(d300, Symmetry::mirror)).rotations, 1);

  // accuracy_cost.csv parses back to the same numbers, row by row, with this parser and with
  // the library's reader.
  write_accuracy_study(st, dir.string());
  const PlainCsv cost = read_plain_csv((dir / "accuracy_cost.csv").string());
  ASSERT_EQ(cost.rows.size(), expected.size());
  const AccuracyCostTable loaded = load_accuracy_cost((dir / "accuracy_cost.csv").string());
  ASSERT_EQ(loaded.rows.size(), expected.size());
  EXPECT_EQ(loaded.cost_unit_vertices, o.cost_unit_vertices);
  expect_written(loaded.reference_relative_sd, ref_sd, "reference_sd");
  std::map<RowKey, int> seen;
  for (size_t i = 0; i < cost.rows.size(); ++i) {
    const auto& q = cost.rows[i];
    auto col = [&](const char* name) { return q.at(cost.column(name)); };
    Method m;
    m.kind = col("kind") == 0 ? MethodKind::discrete : MethodKind::continuum;
    m.order = col("order") == 2 ? WlcExpansion::order2 : WlcExpansion::full;
    m.resolution = static_cast<int>(col("resolution"));
    const Symmetry sym = col("symmetry") == 1 ? Symmetry::mirror : Symmetry::none;
    const auto it = expected.find(key_of(m, sym));
    ASSERT_NE(it, expected.end()) << "row " << i;
    ++seen[it->first];
    const ExpectedRow& e = it->second;
    const std::string what = method_spec(m, sym);
    EXPECT_EQ(col("vertices"), e.vertices) << what;
    EXPECT_EQ(col("elements"), e.elements) << what;
    EXPECT_EQ(col("converged"), e.converged ? 1 : 0) << what;
    EXPECT_EQ(col("rotations"), e.rotations) << what;
    EXPECT_EQ(col("cost_unit_vertices"), o.cost_unit_vertices) << what;
    expect_written(col("error_all"), e.error_all, what + " error_all");
    expect_written(col("error_low"), e.error_low, what + " error_low");
    expect_written(col("error_mid"), e.error_mid, what + " error_mid");
    expect_written(col("error_high"), e.error_high, what + " error_high");
    expect_written(col("error_default"), e.error_default, what + " error_default");
    expect_written(col("cost_eg"), e.cost_eg, what + " cost_eg");
    expect_written(col("spread"), e.spread, what + " spread");
    expect_written(col("reference_sd"), ref_sd, what + " reference_sd");
    // The library's reader: same row, same numbers.
    const AccuracyRow& l = loaded.rows[i];
    EXPECT_EQ(key_of(l.method, l.symmetry), it->first) << what;
    EXPECT_EQ(l.converged, e.converged) << what;
    EXPECT_EQ(l.rotations, e.rotations) << what;
    expect_written(l.error_all, e.error_all, what + " loaded error_all");
    expect_written(l.error_low, e.error_low, what + " loaded error_low");
    expect_written(l.error_mid, e.error_mid, what + " loaded error_mid");
    expect_written(l.error_high, e.error_high, what + " loaded error_high");
    expect_written(l.cost_eg, e.cost_eg, what + " loaded cost_eg");
  }
  EXPECT_EQ(seen.size(), expected.size());  // every row once

  // accuracy_by_force.csv (what `rbc stretch --accuracy` reads): the per-force errors.
  const AccuracyTable by_force = load_accuracy_table((dir / "accuracy_by_force.csv").string());
  ASSERT_EQ(by_force.entries.size(), expected.size());
  expect_written(by_force.reference_relative_se, ref_sd / std::sqrt(2.0), "reference_se");
  for (const AccuracyEntry& a : by_force.entries) {
    const auto it = expected.find(key_of(a.method, a.symmetry));
    ASSERT_NE(it, expected.end()) << method_spec(a.method, a.symmetry);
    EXPECT_EQ(a.forces_pN, o.forces_pN);
    ASSERT_EQ(a.error.size(), nf);
    for (size_t k = 0; k < nf; ++k)
      expect_written(a.error[k], it->second.error_by_force[k], method_spec(a.method, a.symmetry));
    expect_written(a.cost_eg, it->second.cost_eg, method_spec(a.method, a.symmetry));
  }

  // The verdict: per force range and level, the cheapest converged row of each model whose
  // error in that range meets the level; a cost ratio below kAccuracyCostTieRatio is a tie.
  const std::string verdict = accuracy_study_verdict(st);
  const std::pair<Range, std::string> ranges[] = {{Range::all, "- all 13 forces (0-193 pN):"},
                                                  {Range::low, "- F < 50 pN:"},
                                                  {Range::mid, "- 50 <= F < 120 pN:"},
                                                  {Range::high, "- F >= 120 pN:"}};
  int decided = 0;  // level segments where at least one model met the level
  for (const auto& [range, name] : ranges) {
    const size_t at = verdict.find(name);
    ASSERT_NE(at, std::string::npos) << name << "\n" << verdict;
    const std::string line =
        verdict.substr(at + name.size(), verdict.find('\n', at) - at - name.size());
    std::vector<std::string> segments;  // "0.5 %: ...", "1 %: ...", ..., " -> summary"
    std::stringstream ss(line);
    for (std::string s; std::getline(ss, s, ';');) segments.push_back(s);
    ASSERT_EQ(segments.size(), 5u) << line;
    int continuum = 0, discrete = 0, ties = 0;
    const double levels[] = {0.005, 0.01, 0.02, 0.05};
    for (size_t j = 0; j < 4; ++j) {
      const ExpectedRow *d = nullptr, *c = nullptr;
      for (const auto& [key, e] : expected) {
        if (!e.converged || error_in(e, range) > levels[j]) continue;
        const ExpectedRow*& best = e.method.kind == MethodKind::discrete ? d : c;
        if (!best || e.cost_eg < best->cost_eg) best = &e;
      }
      const std::string& seg = segments[j];
      const std::string body = seg.substr(seg.find("%: ") + 3);
      const std::string where = name + " level " + std::to_string(levels[j]) + ": " + body;
      auto spec = [](const ExpectedRow* e) { return method_spec(e->method, e->symmetry) + " ("; };
      if (!d && !c) {
        EXPECT_EQ(body, "neither reaches it") << where;
        continue;
      }
      ++decided;
      if (!d || !c) {
        (c ? continuum : discrete)++;
        EXPECT_EQ(body.rfind(
                      std::string("only ") + (c ? "continuum " : "discrete ") + spec(c ? c : d), 0),
                  0u)
            << where;
        continue;
      }
      const double ratio = std::max(c->cost_eg, d->cost_eg) / std::min(c->cost_eg, d->cost_eg);
      if (ratio < kAccuracyCostTieRatio) {
        ++ties;
        EXPECT_EQ(body.rfind("tie, " + spec(c), 0), 0u) << where;
        EXPECT_NE(body.find(" vs " + spec(d)), std::string::npos) << where;
      } else {
        const bool cont = c->cost_eg < d->cost_eg;
        (cont ? continuum : discrete)++;
        EXPECT_EQ(body.rfind(spec(cont ? c : d), 0), 0u) << where;
        EXPECT_NE(body.find("cheaper than " + spec(cont ? d : c)), std::string::npos) << where;
      }
    }
    EXPECT_EQ(segments[4], " -> continuum cheaper at " + std::to_string(continuum) +
                               ", discrete at " + std::to_string(discrete) + ", tie at " +
                               std::to_string(ties) + " of 4 levels")
        << name;
  }
  // The loosest level (5 %) is within reach of these tiny sizes in every range, so the check
  // above compared chosen rows, not only "neither reaches it".
  EXPECT_GE(decided, 4) << verdict;
}

}  // namespace
}  // namespace accuracy_study_test
}  // namespace rbc
