// SPDX-License-Identifier: GPL-3.0-or-later
#include "compare/accuracy_choice.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>
#include <stdexcept>

#include "compare/experiment.hpp"
#include "core/io.hpp"
#include "core/validation.hpp"

namespace rbc {

namespace {

WlcExpansion order_from_code(double c, const std::string& where) {
  if (c == 0) return WlcExpansion::full;
  if (c == 2) return WlcExpansion::order2;
  if (c == 3) return WlcExpansion::order3;
  if (c == 4) return WlcExpansion::order4;
  throw std::runtime_error(where + ": order must be 0 (full), 2, 3 or 4");
}

std::string percent_text(double fraction) {
  std::ostringstream s;
  s.precision(3);
  s << 100 * fraction << " %";
  return s.str();
}

std::string cost_text(double cost) {
  return std::to_string(std::lround(cost));
}

}  // namespace

std::string method_spec(const Method& m) {
  if (m.kind == MethodKind::discrete) return "discrete:" + std::to_string(m.resolution);
  if (m.loop) return "continuum-loop:" + to_string(m.order) + ":" + std::to_string(m.resolution);
  if (m.adapted || m.refined) {
    std::ostringstream ratio;
    ratio << m.size_ratio;
    return std::string(m.adapted ? "continuum-adapted:" : "continuum-refined:") +
           to_string(m.order) + ":" + std::to_string(m.resolution) + ":" + ratio.str();
  }
  return "continuum:" + to_string(m.order) + ":" + std::to_string(m.resolution);
}

std::string method_spec(const Method& m, Symmetry symmetry) {
  return method_spec(m) + (symmetry == Symmetry::mirror ? " mirror" : "");
}

std::string default_accuracy_table_path() {
  return default_data_directory() + "/tradeoff/accuracy_by_force.csv";
}

namespace {

/// Which mesh (or element) a file's continuum rows were run on.
enum class RowMesh { uniform, adapted, refined, loop };

/// Reads the rows of accuracy_by_force.csv (RowMesh::uniform), accuracy_by_force_adapted.csv,
/// accuracy_by_force_refined.csv or accuracy_by_force_loop.csv (the columns symmetry and
/// size_ratio required; the Loop element's size ratio is 1, its mesh uniform) into `table`.
void read_accuracy_rows(const std::string& path, RowMesh mesh, AccuracyTable& table) {
  const bool adapted = mesh != RowMesh::uniform;  // beside the table: size_ratio column
  const CsvTable t = read_csv(path);
  // The symmetry column came with the mirror rows; a table without it is all Symmetry::none.
  std::vector<std::string> expected = {"kind",    "order",    "resolution", "converged",
                                       "cost_eg", "force_pN", "error",      "reference_se"};
  if (adapted) {
    expected.push_back("symmetry");
    expected.push_back("size_ratio");
  } else if (t.header.size() == expected.size() + 1) {
    expected.push_back("symmetry");
  }
  if (t.header != expected)
    throw std::runtime_error(
        path + ": expected the header kind,order,resolution,converged,cost_eg," +
        "force_pN,error,reference_se" + (adapted ? ",symmetry,size_ratio" : "[,symmetry]"));
  const size_t first = table.entries.size();
  for (size_t k = 0; k < t.rows.size(); ++k) {
    const auto& r = t.rows[k];
    const std::string where = path + " row " + std::to_string(k + 1);
    if (r.size() != expected.size()) throw std::runtime_error(where + ": wrong number of columns");
    for (double v : r)
      if (!std::isfinite(v)) throw std::runtime_error(where + ": non-finite value");
    const bool has_symmetry = r.size() > 8;
    if ((r[0] != 0 && r[0] != 1) || r[2] < 1 || r[2] != std::floor(r[2]) || r[4] < 0 || r[5] < 0 ||
        r[6] < 0 || r[7] < 0 || (has_symmetry && r[8] != 0 && r[8] != 1))
      throw std::runtime_error(where +
                               ": kind must be 0 or 1, resolution a positive integer, "
                               "cost, force, error and reference_se >= 0, symmetry 0 or 1");
    const Symmetry symmetry = has_symmetry && r[8] == 1 ? Symmetry::mirror : Symmetry::none;
    Method m;
    m.kind = r[0] == 0 ? MethodKind::discrete : MethodKind::continuum;
    m.order = m.kind == MethodKind::discrete ? WlcExpansion::full : order_from_code(r[1], where);
    m.resolution = static_cast<int>(r[2]);
    if (adapted) {
      if (m.kind != MethodKind::continuum || !(r[9] >= 1 && r[9] <= 10))
        throw std::runtime_error(where +
                                 ": graded-mesh rows are continuum (kind 1) with size_ratio in "
                                 "[1, 10]");
      m.adapted = mesh == RowMesh::adapted;
      m.refined = mesh == RowMesh::refined;
      m.loop = mesh == RowMesh::loop;
      m.size_ratio = r[9];
    }
    table.reference_relative_se = std::max(table.reference_relative_se, r[7]);
    auto is_this = [&](const AccuracyEntry& e) {
      return e.method.kind == m.kind && e.method.order == m.order &&
             e.method.resolution == m.resolution && e.symmetry == symmetry &&
             e.method.adapted == m.adapted && e.method.refined == m.refined &&
             e.method.loop == m.loop && e.method.size_ratio == m.size_ratio;
    };
    if (table.entries.size() == first || !is_this(table.entries.back())) {
      for (size_t j = first; j < table.entries.size(); ++j)
        if (is_this(table.entries[j]))
          throw std::runtime_error(where + ": rows of " + method_spec(m, symmetry) +
                                   " are not contiguous");
      table.entries.push_back({m, symmetry, r[3] != 0, r[4], {}, {}});
    }
    AccuracyEntry& e = table.entries.back();
    if (!e.forces_pN.empty() && !(r[5] > e.forces_pN.back()))
      throw std::runtime_error(where + ": forces of " + method_spec(m, symmetry) +
                               " must increase");
    e.forces_pN.push_back(r[5]);
    e.error.push_back(r[6]);
  }
  if (table.entries.size() == first) throw std::runtime_error(path + ": the table has no rows");
}

}  // namespace

AccuracyTable load_accuracy_table(const std::string& path) {
  AccuracyTable table;
  table.source = path;
  read_accuracy_rows(path, RowMesh::uniform, table);
  return table;
}

AccuracyTable load_accuracy_table_with_adapted(const std::string& path) {
  AccuracyTable table = load_accuracy_table(path);
  const double se = table.reference_relative_se;
  for (const auto& [name, mesh] : {std::pair{"accuracy_by_force_adapted.csv", RowMesh::adapted},
                                   std::pair{"accuracy_by_force_refined.csv", RowMesh::refined},
                                   std::pair{"accuracy_by_force_loop.csv", RowMesh::loop}}) {
    const std::string file = (std::filesystem::path(path).parent_path() / name).string();
    if (!std::filesystem::exists(file)) continue;
    table.reference_relative_se = 0;
    read_accuracy_rows(file, mesh, table);
    if (std::abs(table.reference_relative_se - se) > 1e-9 * std::max(se, 1e-12))
      throw std::runtime_error(file + ": its reference_se differs from " + path +
                               "'s: the two files are not of the same table");
    table.reference_relative_se = se;
    table.source += " and " + file;
  }
  return table;
}

double parse_accuracy_percent(const std::string& text) {
  std::string s = text;
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.pop_back();
  if (!s.empty() && s.back() == '%') s.pop_back();
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.pop_back();
  const double v = parse_finite_number(s).value_or(0.0);  // unreadable -> refused below
  if (!(v > 0) || v > 100)
    throw std::invalid_argument("--accuracy " + text +
                                ": expected a finite percentage > 0 and <= 100, e.g. 1%");
  return v;
}

double entry_error(const AccuracyEntry& e, const std::vector<double>& forces) {
  const double lo = e.forces_pN.front(), hi = e.forces_pN.back();
  double worst = 0;
  for (double f : forces) {
    if (!(f >= lo && f <= hi)) {
      std::ostringstream m;
      m << "--accuracy: force " << f << " pN lies outside the trade-off table's range [" << lo
        << ", " << hi << "] pN";
      throw std::invalid_argument(m.str());
    }
    const auto it = std::lower_bound(e.forces_pN.begin(), e.forces_pN.end(), f);
    const size_t k = static_cast<size_t>(it - e.forces_pN.begin());
    double err = e.error[k];
    if (*it != f) err = std::max(err, e.error[k - 1]);  // between table forces k-1 and k
    worst = std::max(worst, err);
  }
  return worst;
}

AccuracyChoice choose_by_accuracy(const AccuracyTable& table, const std::vector<double>& forces,
                                  double percent, std::optional<Symmetry> only) {
  if (!std::isfinite(percent) || !(percent > 0))
    throw std::invalid_argument("--accuracy: the percentage must be finite and > 0, got " +
                                std::to_string(percent));
  if (forces.empty()) throw std::invalid_argument("--accuracy: no forces to choose for");
  struct Candidate {
    const AccuracyEntry* entry;
    double error;
    size_t index;
  };
  std::vector<Candidate> ok;
  std::optional<Candidate> best_error;
  size_t on_path = 0;
  for (size_t k = 0; k < table.entries.size(); ++k) {
    const AccuracyEntry& e = table.entries[k];
    const double err = entry_error(e, forces);  // throws for forces outside the table
    if (only && e.symmetry != *only) continue;
    ++on_path;
    if (!e.converged) continue;
    if (!best_error || err < best_error->error) best_error = Candidate{&e, err, k};
    if (err + table.reference_relative_se <= percent / 100) ok.push_back({&e, err, k});
  }
  if (only && on_path == 0)
    throw std::invalid_argument("--accuracy: " + table.source +
                                " has no rows solved with --symmetry " + to_string(*only) +
                                "; drop --symmetry to choose among its rows");
  if (ok.empty()) {
    std::ostringstream m;
    m << "--accuracy " << percent << "%: no method in " << table.source << " reaches it";
    if (best_error)
      m << " (the most accurate, "
        << method_spec(best_error->entry->method, best_error->entry->symmetry) << ", is within "
        << percent_text(best_error->error) << " of the reference, whose own uncertainty is "
        << percent_text(table.reference_relative_se) << ")";
    throw std::invalid_argument(m.str());
  }
  std::stable_sort(ok.begin(), ok.end(), [](const Candidate& a, const Candidate& b) {
    if (a.entry->cost_eg != b.entry->cost_eg) return a.entry->cost_eg < b.entry->cost_eg;
    return a.error < b.error;
  });
  auto pick = [](const Candidate& c) {
    return AccuracyPick{c.entry->method, c.entry->symmetry, c.error, c.entry->cost_eg};
  };
  AccuracyChoice ch;
  ch.percent = percent;
  ch.reference_relative_se = table.reference_relative_se;
  ch.chosen = pick(ok[0]);
  // The alternatives name other discretisations: the same mesh on the other solver path
  // has the same error and is no alternative to report.
  auto same_method = [&](const Candidate& c) {
    const Method &a = c.entry->method, &b = ok[0].entry->method;
    return a.kind == b.kind && a.order == b.order && a.resolution == b.resolution &&
           a.adapted == b.adapted && a.refined == b.refined && a.loop == b.loop &&
           a.size_ratio == b.size_ratio;
  };
  size_t runner = 0;
  for (size_t k = 1; k < ok.size() && !runner; ++k)
    if (!same_method(ok[k])) runner = k;
  if (runner) ch.runner_up = pick(ok[runner]);
  for (size_t k = 1; k < ok.size(); ++k)
    if (ok[k].entry->method.kind != ok[0].entry->method.kind) {
      if (k != runner) ch.other_kind = pick(ok[k]);
      break;
    }
  std::ostringstream r;
  r << "--accuracy " << percent << "%: chose " << method_spec(ch.chosen.method, ch.chosen.symmetry)
    << ", within " << percent_text(ch.chosen.error)
    << " of the reference over the requested forces (+ " << percent_text(ch.reference_relative_se)
    << " reference uncertainty), cost " << cost_text(ch.chosen.cost_eg)
    << " evaluations, the cheapest of " << ok.size() << " that qualify";
  if (ch.runner_up)
    r << "; runner-up " << method_spec(ch.runner_up->method, ch.runner_up->symmetry) << " ("
      << percent_text(ch.runner_up->error) << ", " << cost_text(ch.runner_up->cost_eg) << ")";
  if (ch.other_kind)
    r << "; cheapest "
      << (ch.other_kind->method.kind == MethodKind::discrete ? "discrete" : "continuum")
      << " model " << method_spec(ch.other_kind->method, ch.other_kind->symmetry) << " ("
      << percent_text(ch.other_kind->error) << ", " << cost_text(ch.other_kind->cost_eg) << ")";
  ch.reason = r.str();
  return ch;
}

}  // namespace rbc
