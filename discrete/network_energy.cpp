// SPDX-License-Identifier: GPL-3.0-or-later
#include "discrete/network_energy.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "core/multiversion.hpp"
#include "core/parallel.hpp"

namespace rbc {

namespace {

/// atan2(y, x) in (-pi, pi] by Cephes' atan (S. L. Moshier, Cephes Math Library, atan.c): the
/// ratio |y|/|x| reduced to [0, 0.66] by atan t = pi/2 - atan(1/t) and pi/4 + atan((t-1)/(t+1)),
/// then a degree 4/5 rational approximation (relative error ~1e-16; max |difference| from glibc's
/// atan2 4.4e-16 over 1e7 random arguments spanning 1e-3 to 1e3). About 3x cheaper than glibc's
/// atan2, which was a fifth of an energy evaluation; the hinge angles are its only use. Written
/// without branches (the three ranges pick numerator, denominator and offsets by selects, and
/// adding a zero offset is exact), so loops over it vectorise, with the bits of the branching
/// form.
inline double hinge_atan2(double y, double x) {
  constexpr double kTan3Pi8 = 2.41421356237309504880, kPi = 3.14159265358979323846;
  constexpr double kMoreBits = 6.123233995736765886130e-17;  // pi/2 - double(pi/2)
  const double ay = std::fabs(y), ax = std::fabs(x);
  // t = (|y| - |x|)/(|y| + |x|) with offset pi/4, else t = |y|/|x| with offset 0 (t = 0 at the
  // origin: x + 1 there, x + 0 = x elsewhere), else t = -|x|/|y| with offset pi/2.
  const bool shallow = ay <= 0.66 * ax, steep = ay > kTan3Pi8 * ax;  // never both
  double num = ay - ax, den = ay + ax, base = 0.25 * kPi, more = 0.5 * kMoreBits;
  num = shallow ? ay : num;
  den = shallow ? ax + static_cast<double>(ax == 0) : den;
  base = shallow ? 0.0 : base;
  more = shallow ? 0.0 : more;
  num = steep ? -ax : num;
  den = steep ? ay : den;
  base = steep ? 0.5 * kPi : base;
  more = steep ? kMoreBits : more;
  const double t = num / den;
  const double z = t * t;
  const double p = (((-8.750608600031904122785e-1 * z - 1.615753718733365076637e1) * z -
                     7.500855792314704667340e1) *
                        z -
                    1.228866684490136173410e2) *
                       z -
                   6.485021904942025371773e1;
  const double q = ((((z + 2.485846490142306297962e1) * z + 1.650270098316988542046e2) * z +
                     4.328810604912902668951e2) *
                        z +
                    4.853903996359136964868e2) *
                       z +
                   1.945506571482613964425e2;
  const double a = base + (t * z * p / q + t) + more;  // in [0, pi/2]
  return std::copysign(x < 0 ? kPi - a : a, y);
}

/// Elements per block of the geometry loops: each block first gathers its vertices (scalar,
/// indexed loads) into local arrays, then takes the square roots and divisions in a loop over
/// those arrays, which the compiler vectorises (the loops are bound by division throughput).
constexpr int kGeometryBlock = 128;

/// Faces [begin, end) of network_geometry: normals, areas and their sums (um^2, um^3).
/// Compiled for x86-64-v3 too (core/multiversion.hpp).
RBC_HOT_CLONES void face_geometry(const Positions& x, const Topology& topo, NetworkGeometry& g,
                                  int begin, int end, double& area_um2, double& volume_um3) {
  double sa = 0, sv = 0;
  double norm2[kGeometryBlock], triple[kGeometryBlock];
  double* __restrict area = g.face_area.data();
  double* __restrict inv_norm = g.face_inv_norm2.data();
  for (int b0 = begin; b0 < end; b0 += kGeometryBlock) {
    const int n = std::min(kGeometryBlock, end - b0);
    for (int i = 0; i < n; ++i) {
      const int f = b0 + i;
      const auto a = x.col(topo.faces(0, f)), b = x.col(topo.faces(1, f)),
                 d = x.col(topo.faces(2, f));
      const Eigen::Vector3d m = (b - a).cross(d - a);
      g.face_normal2.col(f) = m;
      norm2[i] = m.squaredNorm();
      triple[i] = a.dot(b.cross(d));
    }
    for (int i = 0; i < n; ++i) {
      const double twice = std::sqrt(norm2[i]);  // = m.norm()
      area[b0 + i] = 0.5 * twice;
      inv_norm[b0 + i] = 1.0 / twice;
      triple[i] /= 6.0;
    }
    for (int i = 0; i < n; ++i) sa += area[b0 + i], sv += triple[i];  // in order: the same sums
  }
  area_um2 = sa;
  volume_um3 = sv;
}

/// Edges [begin, end) of network_geometry: lengths, their inverses and the hinge angles.
/// Compiled for x86-64-v3 too (core/multiversion.hpp).
RBC_HOT_CLONES void hinge_geometry(const Positions& x, const Topology& topo, NetworkGeometry& g,
                                   int begin, int end) {
  double len2[kGeometryBlock], sine[kGeometryBlock], cosine[kGeometryBlock];
  double* __restrict length = g.edge_length.data();
  double* __restrict inv_length = g.edge_inv_length.data();
  double* __restrict angle = g.hinge_angle.data();
  for (int b0 = begin; b0 < end; b0 += kGeometryBlock) {
    const int n = std::min(kGeometryBlock, end - b0);
    for (int i = 0; i < n; ++i) {
      const int e = b0 + i;
      const Eigen::Vector3d ed = x.col(topo.edges(1, e)) - x.col(topo.edges(0, e));
      const auto m0 = g.face_normal2.col(topo.edge_faces(0, e));
      const auto m1 = g.face_normal2.col(topo.edge_faces(1, e));
      len2[i] = ed.squaredNorm();
      sine[i] = m0.cross(m1).dot(ed);
      cosine[i] = m0.dot(m1);
    }
    for (int i = 0; i < n; ++i) {
      const double len = std::sqrt(len2[i]);  // = ed.norm()
      length[b0 + i] = len;
      inv_length[b0 + i] = 1.0 / len;
      angle[b0 + i] = hinge_atan2(sine[i], len * cosine[i]);
    }
  }
}

/// Edges [begin, end) of assemble_geometric_gradient (see there), cloned as hinge_geometry.
RBC_HOT_CLONES void assemble_edges(const Positions& x, const Topology& topo,
                                   const NetworkGeometry& geo, const GeometricGradient& c,
                                   int begin, int end, Positions& g) {
  const double cv = c.volume / 6.0;
  for (int e = begin; e < end; ++e) {
    const int ia = topo.edges(0, e), ib = topo.edges(1, e);
    const int ic = topo.edge_opposite(0, e), id = topo.edge_opposite(1, e);
    const int f0 = topo.edge_faces(0, e), f1 = topo.edge_faces(1, e);
    const auto a = x.col(ia), b = x.col(ib);
    const Eigen::Vector3d ed = b - a;
    const auto m0 = geo.face_normal2.col(f0), m1 = geo.face_normal2.col(f1);
    const double len = geo.edge_length[e], inv_len = geo.edge_inv_length[e];
    const double i0 = geo.face_inv_norm2[f0], i1 = geo.face_inv_norm2[f1];
    // Edge length: dL/db = e/L = -dL/da.
    const Eigen::Vector3d dl = (c.edge_length[e] * inv_len) * ed;
    // Faces f0 at c and f1 at d (area with the uniform tension c.area, and volume).
    const Eigen::Vector3d vol = cv * a.cross(b);
    Eigen::Vector3d gc = (0.5 * (c.face_area[f0] + c.area) * i0) * m0.cross(ed) + vol;
    Eigen::Vector3d gd = (-0.5 * (c.face_area[f1] + c.area) * i1) * m1.cross(ed) - vol;
    Eigen::Vector3d ga = -dl, gb = dl;
    // Hinge angle, as core/geometry.hpp dihedral_angle's gradient: dtheta/dc = -L m0/|m0|^2,
    // dtheta/dd = -L m1/|m1|^2, a and b from t_c, t_d.
    const double ct = c.hinge_angle[e];
    if (ct != 0.0) {
      const Eigen::Vector3d hc = (-ct * len * i0 * i0) * m0;
      const Eigen::Vector3d hd = (-ct * len * i1 * i1) * m1;
      const double inv_l2 = inv_len * inv_len;
      const double tc = (x.col(ic) - a).dot(ed) * inv_l2, td = (x.col(id) - a).dot(ed) * inv_l2;
      ga -= (1.0 - tc) * hc + (1.0 - td) * hd;
      gb -= tc * hc + td * hd;
      gc += hc;
      gd += hd;
    }
    g.col(ia) += ga;
    g.col(ib) += gb;
    g.col(ic) += gc;
    g.col(id) += gd;
  }
}

}  // namespace

NetworkGeometry network_geometry(const Positions& x, const Topology& topo) {
  const int nf = topo.num_faces(), ne = topo.num_edges();
  NetworkGeometry g;
  g.face_normal2.resize(3, nf);
  g.face_area.resize(nf);
  g.face_inv_norm2.resize(nf);
  g.edge_length.resize(ne);
  g.edge_inv_length.resize(ne);
  g.hinge_angle.resize(ne);
  double area[kMaxChunks] = {0, 0, 0, 0}, volume[kMaxChunks] = {0, 0, 0, 0};
  // Faces: the same operations, in the same chunks, as triangle_area/total_area and
  // tetra_volume/enclosed_volume (core/geometry), so the totals carry the same bits.
  // Hinges: theta = atan2((m0 x m1).e/|e|, m0.m1) with m0, m1 the normals of the faces that
  // traverse e forwards and backwards (= e x (c - a) and (a - b) x (d - b)); the 1/|e| is moved
  // to the second argument so that a zero-length edge gives atan2(0, 0) rather than 0/0. They
  // read the face normals, so the edge chunks start after every face chunk has finished.
  const auto faces = [&](int c, int begin, int end) {
    face_geometry(x, topo, g, begin, end, area[c], volume[c]);
  };
  const auto hinges = [&](int, int begin, int end) { hinge_geometry(x, topo, g, begin, end); };
  for_each_chunk_pair(nf, faces, ne, hinges, Then::after);
  for (int c = 0; c < assembly_chunks(nf); ++c) g.area_um2 += area[c], g.volume_um3 += volume[c];
  return g;
}

GeometricGradient GeometricGradient::zero(const Topology& topo, Positions* direct) {
  GeometricGradient c;
  c.face_area.assign(topo.num_faces(), 0.0);
  c.edge_length.assign(topo.num_edges(), 0.0);
  c.hinge_angle.assign(topo.num_edges(), 0.0);
  c.direct = direct;
  return c;
}

void assemble_geometric_gradient(const Positions& x, const Topology& topo,
                                 const NetworkGeometry& geo, const GeometricGradient& c,
                                 Positions& grad) {
  const int ne = topo.num_edges();
  const int chunks = assembly_chunks(ne);
  // One pass over the edges carries the faces' terms too: a face's derivative at vertex k is
  // dA_f/dx_k = n_f x (x_{k+2} - x_{k+1})/2 and dV_f/dx_k = x_{k+1} x x_{k+2}/6 (cyclic), a
  // function of the edge opposite k. Edge e = (a, b) is traversed a -> b by face f0, whose
  // vertex opposite is c, and b -> a by f1, opposite d; so e adds f0's terms at c and f1's at
  // d, and every (face, vertex) pair is visited once. Each vertex column is written once per
  // edge (four scattered updates, where the edge and face loops took about eight: 6 per edge plus 3
  // per face, F = 2E/3).
  assemble_chunks(ne, &grad, [&](int chunk, Positions& g) {
    assemble_edges(x, topo, geo, c, chunk_begin(ne, chunks, chunk),
                   chunk_begin(ne, chunks, chunk + 1), g);
  });
}

}  // namespace rbc
