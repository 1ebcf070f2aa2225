#pragma once
// A sparse symmetric positive-definite approximation of the network energy's Hessian,
// used to precondition L-BFGS (STYLE.md: the minimiser, not the physics, lives here).
#include <Eigen/Sparse>

#include "discrete/network.hpp"

namespace rbc {

/// 3N x 3N lower-triangular-complete symmetric matrix (pN/um), the sum of
///  - links: the exact link Hessian sqrt3 (V' I + 2 V'' d d^T / Lbar^2), with V' and V''
///    clamped at zero (Taylor laws may soften in compression);
///  - steric faces: Gauss-Newton s''(J)/Abar dA dA^T (convex in J; the indefinite
///    s'(J) d2A part is dropped);
///  - Juelicher bending: Gauss-Newton kappa/A_i dM_i dM_i^T per vertex star;
///  - a shift `shift_fraction` x mean diagonal, which makes the 6 rigid-body modes (and
///    the constraint directions the matrix omits) positive.
/// Constraint and tweezers terms are omitted (rank-one and linear: L-BFGS learns them).
Eigen::SparseMatrix<double> approximate_hessian(const Network& net, const Positions& x,
                                                double shift_fraction = 1e-4);

}  // namespace rbc
