// SPDX-License-Identifier: GPL-3.0-or-later
#include "core/symmetry_stability.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>

namespace rbc {

struct SymmetryStabilityCheck::Sector {
  int character = 0;
  SymmetryReduction reduction;
  std::unique_ptr<ReducedMatrix> map;
  SparseCholesky cholesky;
  Sector(int c, SymmetryReduction r, const SparseCholeskyOptions& o)
      : character(c), reduction(std::move(r)), cholesky(o) {}
};

SymmetryStabilityCheck::SymmetryStabilityCheck(const MeshSymmetry& symmetry,
                                               const SparseCholeskyOptions& options)
    : options_(options) {
  for (int c : nontrivial_characters(symmetry)) {
    auto s = std::make_unique<Sector>(c, make_symmetry_reduction(symmetry, c), options);
    if (s->reduction.reduced_size > 0) sectors_.push_back(std::move(s));
  }
}

SymmetryStabilityCheck::~SymmetryStabilityCheck() = default;

double rigid_turn_residual_curvature(const Eigen::Matrix3Xd& x, const Eigen::Matrix3Xd& r) {
  const Eigen::Vector3d c = x.rowwise().mean();
  double worst = 0.0;
  for (int k = 0; k < 3; ++k) {
    const Eigen::Vector3d w = Eigen::Vector3d::Unit(k);
    double rd = 0.0, dd = 0.0;
    for (Eigen::Index i = 0; i < x.cols(); ++i) {
      const Eigen::Vector3d xi = x.col(i) - c;
      rd += r.col(i).dot(w.cross(w.cross(xi)));
      dd += w.cross(xi).squaredNorm();
    }
    if (dd > 0) worst = std::max(worst, rd / dd);
  }
  return worst;
}

bool SymmetryStabilityCheck::factorise(Sector& s, const Eigen::SparseMatrix<double>& r,
                                       double relative_shift, double absolute_shift) {
  if (!r.isCompressed()) {
    Eigen::SparseMatrix<double> compressed = r;
    compressed.makeCompressed();
    return factorise(s, compressed, relative_shift, absolute_shift);
  }
  // The shift's scale: the mean |diagonal| (found afresh each call, a pass over the pattern;
  // the Cholesky re-analyses a changed pattern by itself).
  double scale = 0.0;
  for (Eigen::Index c = 0; c < r.outerSize(); ++c) {
    const int* begin = r.innerIndexPtr() + r.outerIndexPtr()[c];
    const int* end = r.innerIndexPtr() + r.outerIndexPtr()[c + 1];
    const int* d = std::lower_bound(begin, end, static_cast<int>(c));
    if (d == end || *d != c)
      throw std::logic_error("stability check: a sector matrix lacks a diagonal entry");
    scale += std::abs(r.valuePtr()[d - r.innerIndexPtr()]);
  }
  scale /= static_cast<double>(std::max<Eigen::Index>(r.rows(), 1));
  return s.cholesky.factorize(r, relative_shift * scale + absolute_shift);
}

SectorStability SymmetryStabilityCheck::check(const Eigen::SparseMatrix<double>& h,
                                              double relative_shift, double absolute_shift) {
  return check_sectors(
      [&](int k) -> const Eigen::SparseMatrix<double>& {
        Sector& s = *sectors_[static_cast<size_t>(k)];
        if (!s.map || !s.map->matches(h)) s.map = std::make_unique<ReducedMatrix>(s.reduction, h);
        return s.map->reduce(h);
      },
      relative_shift, absolute_shift);
}

SectorStability SymmetryStabilityCheck::check_sectors(
    const std::function<const Eigen::SparseMatrix<double>&(int k)>& sector_matrix,
    double relative_shift, double absolute_shift) {
  if (!(relative_shift >= 0) || !std::isfinite(relative_shift) || !(absolute_shift >= 0) ||
      !std::isfinite(absolute_shift))
    throw std::invalid_argument("stability check: the shifts must be finite and >= 0");
  SectorStability out;
  for (size_t k = 0; k < sectors_.size(); ++k) {
    Sector& s = *sectors_[k];
    ++out.factorisations;
    if (!factorise(s, sector_matrix(static_cast<int>(k)), relative_shift, absolute_shift)) {
      out.stable = false;
      out.unstable_character = s.character;
      return out;
    }
  }
  return out;
}

int SymmetryStabilityCheck::character(int k) const {
  return sectors_.at(static_cast<size_t>(k))->character;
}

const SymmetryReduction& SymmetryStabilityCheck::sector_reduction(int k) const {
  return sectors_.at(static_cast<size_t>(k))->reduction;
}

Eigen::VectorXd SymmetryStabilityCheck::sector_direction(int character, unsigned seed) const {
  for (const auto& sp : sectors_)
    if (sp->character == character) {
      std::mt19937_64 rng(seed);
      std::normal_distribution<double> normal;
      Eigen::VectorXd q(sp->reduction.reduced_size);
      for (auto& v : q) v = normal(rng);
      Eigen::VectorXd d = expand(sp->reduction, q);
      return d / d.norm();
    }
  throw std::invalid_argument("stability check: no sector of character " +
                              std::to_string(character));
}

}  // namespace rbc
