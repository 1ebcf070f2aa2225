// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// A tiny accuracy study for the tests of the rows written beside the trade-off table (refined
// mesh, Loop element): two forces, a 300-vertex reference on two rotations, one spread rotation,
// no rows of the table's own methods.
#include <algorithm>
#include <cmath>
#include <functional>
#include <vector>

#include "compare/accuracy_study.hpp"

namespace rbc::testing {

inline AccuracyStudyOptions tiny_study_options() {
  AccuracyStudyOptions o;
  o.forces_pN = {0, 80};
  o.discrete_vertices = {};
  o.continuum_elements = {};
  o.reference_vertices = 300;
  o.reference_seeds = {0, 1};
  o.spread_seeds = {1};
  o.cost_unit_vertices = 150;
  return o;
}

/// The sweeps of the methods `is_kind` picks: those on the full path, the count on the mirror
/// path, and per force the largest relative error of D_A and D_T of the full ones against the
/// study's reference (what their rows' errors must be).
struct KindSweeps {
  std::vector<const MethodRun*> full;
  int mirror = 0;
  std::vector<double> worst;
};
inline KindSweeps kind_sweeps(const AccuracyStudy& st,
                              const std::function<bool(const Method&)>& is_kind) {
  KindSweeps k;
  for (const StudyRun& s : st.runs)
    if (is_kind(s.run.method)) {
      if (s.run.symmetry == Symmetry::mirror)
        ++k.mirror;
      else
        k.full.push_back(&s.run);
    }
  k.worst.assign(st.reference.size(), 0.0);
  for (const MethodRun* r : k.full)
    for (std::size_t f = 0; f < st.reference.size(); ++f)
      k.worst[f] = std::max(
          {k.worst[f],
           std::abs(r->points[f].axial_um - st.reference[f].axial_um) / st.reference[f].axial_um,
           std::abs(r->points[f].transverse_um - st.reference[f].transverse_um) /
               st.reference[f].transverse_um});
  return k;
}

}  // namespace rbc::testing
