# SPDX-License-Identifier: GPL-3.0-or-later
"""rbc: multiscale red blood cell membrane mechanics (Hartmann 2008) from Python.

The compiled core (``rbc._rbc``, pybind11) binds the C++ libraries directly -- not the ``rbc``
executable -- so the numbers are the CLI's for the same inputs. Units are in the names:
lengths in um, forces in pN, energies in pN*um inside; physical inputs in natural units
(``persistence_nm``, ``kappa_J``, ``wlc_temperature_K``), converted once. Positions are
``(N, 3)`` float64 arrays in um, faces ``(F, 3)`` int32.

Long solves release the GIL (Python threads can run several at once) and poll Ctrl-C: a
KeyboardInterrupt cancels them. Process pools must use the ``spawn`` start method once OpenMP
has run in the parent (``multiprocessing.get_context("spawn")``): a forked child inherits
OpenMP's thread pool in an unusable state and can hang.

Example::

    import rbc
    res = rbc.stretch("discrete", forces_pN=[0, 88], vertices=500)
    print(res.axial_um, res.transverse_um)       # D_A, D_T per force (um)
    net = rbc.Network(rbc.rest_shape(500))
    e, g = rbc.network_energy(net, net.rest_positions, force_pN=88.0)
"""
from __future__ import annotations

import dataclasses
import enum
import math
from typing import Any, Callable, Optional, Sequence

import numpy as np

from . import _rbc
from ._rbc import (  # noqa: F401  (re-exported API)
    BendingModel,
    BendingParameters,
    ConstraintMultipliers,
    ConstraintParameters,
    ContactParameters,
    ConvergenceError,
    DihedralMapping,
    InferenceProblem,
    Mesh,
    MeshQuality,
    MeshQualityReport,
    MonteCarlo,
    Network,
    Order,
    PatchRule,
    StericParameters,
    WlcParameters,
    blas_info,
    continuum_mesh,
    diameters,
    moduli,
    network_energy,
    network_energy_parts,
    psi,
    rest_shape,
    thermal_energy_pNum,
)

#: The version of the compiled core, as `rbc --version` prints it (e.g. "0.1.0+g5a3eb55").
__version__ = _rbc.__version__

#: The forces of `rbc stretch` (pN): those of Mills et al. 2004.
DEFAULT_FORCES_PN = (0.0, 16.0, 19.5, 30.6, 38.0, 46.6, 67.6, 87.6, 108.8, 130.0, 151.0, 172.8,
                     193.0)


class Model(enum.Enum):
    """Which model a stretch runs (strings accepted: 'discrete', 'continuum')."""

    discrete = "discrete"
    continuum = "continuum"

    @classmethod
    def of(cls, value: "Model | str") -> "Model":
        if isinstance(value, cls):
            return value
        try:
            return cls(value)
        except ValueError:
            raise ValueError(f"model {value!r} is not one of discrete, continuum") from None


@dataclasses.dataclass(repr=False)
class StretchPoint:
    """One equilibrium of a stretch (plain data: picklable, arrays own or view their memory)."""

    force_pN: float
    axial_um: float  #: D_A = max x - min x
    transverse_um: float  #: D_T, widest extent perpendicular to x
    energy_pNum: float  #: free energy without the constraint terms
    iterations: int
    converged: bool
    status: str
    residual_pN: float  #: largest net vertex force at the end
    area_drift: float  #: (A - A0)/A0
    volume_drift: float  #: (V - V0)/V0
    wall_s: float
    vertices: int
    elements: int  #: continuum triangles (0 for the discrete network)
    positions: np.ndarray  #: (N, 3) equilibrium positions, um
    faces: np.ndarray  #: (F, 3) int32
    rest_positions: np.ndarray  #: (N, 3) reference positions, um
    area_multiplier_pN_per_um: float
    volume_multiplier_pN_per_um2: float
    stiffness_scale: float = 1.0  #: discrete: penalty scale of the last minimisation
    factorisations: int = 0  #: discrete: preconditioner factorisations
    substeps: int = 1  #: continuum: forces solved to reach this one
    fields: dict = dataclasses.field(default_factory=dict)  #: continuum per-element fields
    #: symmetry='mirror': the order of the mirror group of the force's last solve (1 = solved
    #: in full) and whether the equilibrium is not mirror-symmetric (a buckled state); None
    #: when the stretch ran with symmetry='none'
    symmetry_order: Optional[int] = None
    symmetry_broken: Optional[bool] = None

    def __repr__(self) -> str:
        size = f"{self.vertices} vertices" + (f", {self.elements} elements" if self.elements
                                             else "")
        return (f"StretchPoint(force_pN={self.force_pN:g}, axial_um={self.axial_um:.4f}, "
                f"transverse_um={self.transverse_um:.4f}, converged={self.converged}, "
                f"residual_pN={self.residual_pN:.2e}, {size}; positions "
                f"{tuple(self.positions.shape)})")

    def record(self) -> dict:
        """The fields of one point of `rbc stretch --json`."""
        r = {k: getattr(self, k) for k in ("force_pN", "axial_um", "transverse_um", "energy_pNum",
                                           "iterations", "converged", "wall_s", "vertices")}
        if self.elements:
            r["elements"] = self.elements
        r.update(residual_pN=self.residual_pN, area_drift=self.area_drift,
                 volume_drift=self.volume_drift)
        if self.symmetry_order is not None:
            r.update(symmetry_order=self.symmetry_order, symmetry_broken=self.symmetry_broken)
        return r

    def to_meshio(self):
        """The equilibrium shape as a meshio.Mesh (point data: displacement_um; continuum cell
        data: I1, I2, principal tensions)."""
        import meshio

        u = np.linalg.norm(self.positions - self.rest_positions, axis=1)
        cell_data = {k: [np.asarray(v)] for k, v in self.fields.items()}
        return meshio.Mesh(np.asarray(self.positions), [("triangle", np.asarray(self.faces))],
                           point_data={"displacement_um": u}, cell_data=cell_data,
                           field_data={"force_pN": np.array([self.force_pN])})


class StretchResult(Sequence):
    """Results of rbc.stretch: a sequence of StretchPoint, with per-force arrays."""

    def __init__(self, model: Model, points: list, mesh: Mesh, network: Optional[Network],
                 largest_rest_inplane_force_pN: Optional[float], law: Optional[str], polls: int):
        self.model = model
        self.points = points
        self.mesh = mesh  #: the rest mesh (network or continuum elements)
        self.network = network  #: the discrete Network (None for the continuum model)
        self.largest_rest_inplane_force_pN = largest_rest_inplane_force_pN
        self.law = law  #: continuum in-plane law name
        self._cancel_polls = polls

    def __len__(self):
        return len(self.points)

    def __getitem__(self, i):
        return self.points[i]

    def _column(self, name, dtype=float):
        return np.array([getattr(p, name) for p in self.points], dtype=dtype)

    @property
    def mesh_quality(self) -> MeshQualityReport:
        return self.mesh.quality

    @property
    def forces_pN(self):
        return self._column("force_pN")

    @property
    def axial_um(self):
        return self._column("axial_um")

    @property
    def transverse_um(self):
        return self._column("transverse_um")

    @property
    def diameters_um(self):
        """(M, 2): D_A, D_T per force."""
        return np.column_stack([self.axial_um, self.transverse_um])

    @property
    def energy_pNum(self):
        return self._column("energy_pNum")

    @property
    def residual_pN(self):
        return self._column("residual_pN")

    @property
    def converged(self):
        return self._column("converged", bool)

    @property
    def status(self):
        return [p.status for p in self.points]

    def to_records(self) -> list:
        """The JSON array `rbc stretch --json` prints, as a list of dicts."""
        return [p.record() for p in self.points]

    def __repr__(self):
        return (f"StretchResult(model={self.model.value!r}, {len(self.points)} forces "
                f"{self.forces_pN.tolist()} pN, D_A {np.round(self.axial_um, 4).tolist()} um, "
                f"converged {int(self.converged.sum())}/{len(self.points)})")


def _points(model, raw, rest_positions, faces, symmetry):
    mirror = symmetry == "mirror"
    out = []
    for p in raw:
        common = dict(
            force_pN=p.force_pN, axial_um=p.axial_um, transverse_um=p.transverse_um,
            energy_pNum=p.energy_pNum, iterations=p.iterations, converged=p.converged,
            status=p.status, residual_pN=p.residual_pN, area_drift=p.area_drift,
            volume_drift=p.volume_drift, wall_s=p.wall_s, vertices=p.vertices,
            positions=p.positions, faces=faces, rest_positions=rest_positions,
            area_multiplier_pN_per_um=p.multipliers.area_pN_per_um,
            volume_multiplier_pN_per_um2=p.multipliers.volume_pN_per_um2,
            symmetry_order=p.symmetry_order if mirror else None,
            symmetry_broken=p.symmetry_broken if mirror else None)
        if model is Model.discrete:
            out.append(StretchPoint(elements=0, stiffness_scale=p.stiffness_scale,
                                    factorisations=p.factorisations, **common))
        else:
            out.append(StretchPoint(elements=p.elements, substeps=p.substeps, fields=p.fields,
                                    **common))
    return out


def _force_list(forces_pN) -> list:
    """One force or a sequence of forces (pN) as a list of floats; ValueError otherwise."""
    forces = np.asarray(forces_pN, dtype=float)
    if forces.ndim > 1:
        raise ValueError(f"forces_pN: expected a force or a list of forces in pN, got an array "
                         f"of shape {forces.shape}")
    return np.atleast_1d(forces).tolist()


def stretch(model: "Model | str" = "discrete",
            forces_pN: "float | Sequence[float]" = DEFAULT_FORCES_PN, *,
            vertices: int = 2000, elements: int = 4000, order: "Order | str | int" = "2",
            wlc: Optional[WlcParameters] = None, bending: Optional[BendingParameters] = None,
            steric: Optional[StericParameters] = None, contact: Optional[ContactParameters] = None,
            constraints: Optional[ConstraintParameters] = None,
            mesh_quality: "MeshQuality | str" = "phi-minimised",
            mesh_orientation: str = "dimple-vertex", network: Optional[Network] = None,
            tolerance_pN: Optional[float] = None, max_iterations: Optional[int] = None,
            symmetry: str = "none", check: bool = False,
            cancel: Optional[Callable[[], bool]] = None,
            progress: Optional[Callable[[str], None]] = None) -> StretchResult:
    """Optical-tweezers stretch by continuation over forces_pN, as ``rbc stretch``.

    model 'discrete': the spectrin network on a rest shape of about `vertices` vertices (or the
    given `network`), L-BFGS to `tolerance_pN` (default 1e-3 pN) with augmented-Lagrangian area
    and volume, `max_iterations` (default 50,000) per force. model 'continuum': surface finite
    elements (`elements` triangles, law of `order` 2, 3, 4 or 'full'), sparse Newton with exact
    constraints (force tolerance 1e-6 pN unless `tolerance_pN` is given; at most 1,000
    iterations, as the CLI).

    symmetry='mirror' (``rbc stretch --symmetry mirror``, both models) solves on the states
    symmetric under the coordinate mirrors the mesh and the bead load share (|G| times fewer
    unknowns); each symmetric equilibrium is checked for stability and, where it is a saddle
    (the cell buckles), solved again in full. Each point then carries symmetry_order (1 =
    solved in full) and symmetry_broken (the equilibrium is not symmetric).

    mesh_orientation='mirror-planes' (``rbc stretch --mesh-orientation mirror-planes``) lays
    the triangulation so that it keeps all three coordinate mirrors (symmetry='mirror' then
    solves one eighth of the cell) and cuts the bead patches between x levels
    (ContactParameters(level_patch=True)): another discretisation of the same cell.

    Every force gets a status and residual; non-convergence raises rbc.ConvergenceError (a
    RuntimeError with .residual_pN, .force_pN and .result) only when check=True. The GIL is
    released while solving; Ctrl-C, or `cancel()` returning True, stops the solve with
    KeyboardInterrupt. `progress(message)` receives the library's progress lines.

    forces_pN is one force or a sequence of forces. Forces must be finite and within the model's
    documented range, as for ``rbc stretch``:
    [0, 500] pN for the discrete model, [0, 400] pN for the continuum model; anything else
    raises ValueError naming the force and the limit before any work.
    """
    model = Model.of(model)
    forces_pN = _force_list(forces_pN)
    # The library's limits (finite forces within the model's documented maximum), before any
    # mesh or network is built.
    _rbc._validate_forces(model.value, forces_pN)
    if mesh_orientation == "mirror-planes":  # the patch that keeps the mesh's mirrors
        c = contact if contact is not None else ContactParameters()
        contact = ContactParameters(fraction=c.fraction, rule=c.rule, level_patch=True)
    if model is Model.discrete:
        if network is None:
            mesh = rest_shape(vertices, mesh_quality, orientation=mesh_orientation)
            network = Network(mesh, wlc=wlc, bending=bending, steric=steric, contact=contact,
                              constraints=constraints)
        elif mesh_orientation != "dimple-vertex":
            raise ValueError("mesh_orientation applies to the mesh stretch() builds; a given "
                             "network carries its own (build it on rbc.rest_shape(..., "
                             "orientation=...))")
        elif any(p is not None for p in (wlc, bending, steric, contact, constraints)):
            raise ValueError("give either network or its parameters (wlc, bending, steric, "
                             "contact, constraints), not both")
        raw, info = _rbc._stretch_discrete(network, forces_pN, tolerance_pN, max_iterations,
                                           symmetry, cancel, progress)
        result = StretchResult(model, _points(model, raw, network.rest_positions, network.faces,
                                              symmetry),
                               network.mesh, network, network.largest_rest_inplane_force_pN(),
                               None, info["polls"])
    else:
        if network is not None:
            raise ValueError("network applies to model='discrete' only")
        raw, info = _rbc._stretch_continuum(elements, order, wlc, bending, steric, contact,
                                            forces_pN, tolerance_pN, max_iterations, symmetry,
                                            mesh_orientation, cancel, progress)
        mesh = info["mesh"]
        result = StretchResult(model, _points(model, raw, mesh.positions, mesh.faces, symmetry),
                               mesh, None, None, info["law"], info["polls"])
    if check:
        for p in result.points:
            if not p.converged:
                err = ConvergenceError(
                    f"force {p.force_pN:g} pN did not converge ({p.status}): largest vertex force "
                    f"residual {p.residual_pN:.3e} pN, area drift {p.area_drift:.3e}, volume "
                    f"drift {p.volume_drift:.3e}")
                err.residual_pN = p.residual_pN
                err.force_pN = p.force_pN
                err.result = result
                raise err
    return result


def network_hessian(network: Network, positions, *, area_multiplier_pN_per_um: float = 0.0,
                    volume_multiplier_pN_per_um2: float = 0.0, stiffness_scale: float = 1.0,
                    exact: bool = True, penalty: bool = False, shift_fraction: float = 0.0):
    """Hessian (pN/um) of rbc.network_energy at `positions` as a scipy.sparse CSR matrix of
    size 3N x 3N, ordered like the flat positions (x0, y0, z0, x1, ...).

    exact=True: the exact Hessian of links, steric faces, Juelicher bending and the constraint
    curvature (sigma d2A + p d2V) -- for the dihedral model the bending part is its Gauss-Newton
    term; exact=False: the projected (positive semidefinite) Newton matrix the solver factorises.
    The area/volume penalty's rank-two part s kA dA dA^T + s kV dV dV^T makes the matrix dense;
    it is added only with penalty=True (then it is the full Hessian; use for small N) -- or use
    network_hessian_operator(). The tweezers work is linear and adds nothing.
    """
    import scipy.sparse

    d = _rbc._network_hessian(network, positions, area_multiplier_pN_per_um,
                              volume_multiplier_pN_per_um2, stiffness_scale, exact, shift_fraction)
    n = d["size"]
    # The library's matrix is symmetric: its column-major (CSC) arrays are its CSR arrays.
    h = scipy.sparse.csr_matrix((d["data"], d["indices"], d["indptr"]), shape=(n, n))
    if penalty:
        a = d["area_gradient"].reshape(-1)
        v = d["volume_gradient"].reshape(-1)
        dense = d["area_weight"] * np.outer(a, a) + d["volume_weight"] * np.outer(v, v)
        h = scipy.sparse.csr_matrix(h + dense)
    return h


def network_hessian_operator(network: Network, positions, *, area_multiplier_pN_per_um=0.0,
                             volume_multiplier_pN_per_um2=0.0, stiffness_scale=1.0, exact=True):
    """The full Hessian (sparse part + the penalty's rank-two part) as a
    scipy.sparse.linalg.LinearOperator, for Newton-CG / trust-region solvers at any N."""
    from scipy.sparse.linalg import LinearOperator

    d = _rbc._network_hessian(network, positions, area_multiplier_pN_per_um,
                              volume_multiplier_pN_per_um2, stiffness_scale, exact, 0.0)
    import scipy.sparse

    n = d["size"]
    h = scipy.sparse.csr_matrix((d["data"], d["indices"], d["indptr"]), shape=(n, n))
    a = d["area_gradient"].reshape(-1)
    v = d["volume_gradient"].reshape(-1)
    wa, wv = d["area_weight"], d["volume_weight"]

    def matvec(x):
        x = np.asarray(x).reshape(-1)
        return h @ x + wa * a * (a @ x) + wv * v * (v @ x)

    return LinearOperator((n, n), matvec=matvec, rmatvec=matvec, dtype=float)


def infer(problem: Optional[InferenceProblem] = None, *,
          cancel: Optional[Callable[[], bool]] = None,
          progress: Optional[Callable[[str], None]] = None, **options) -> dict:
    """Bayesian calibration by TMCMC, as ``rbc infer``: the posterior of the inferred parameters
    given force-diameter data (MODEL.md section 7).

    Pass an rbc.InferenceProblem, or its keyword arguments (parameters=['persistence', 'lmax',
    'sigma-scale'], priors={name: (lower, upper)}, method='continuum:2:1000', data_file,
    samples=500, seed=1, ...; the CLI's defaults). Returns the fields of ``rbc infer --json``
    plus 'samples' (S, P) in natural units, 'log_likelihood_samples', the derived
    'mu_uN_per_m_samples' and 'K_uN_per_m_samples', and 'stage_info'. The GIL is released;
    Ctrl-C or cancel() returning True stops between stages with KeyboardInterrupt.
    """
    if problem is None:
        problem = InferenceProblem(**options)
    elif options:
        raise ValueError("give either an InferenceProblem or its options, not both")
    return _rbc._infer(problem, cancel, progress)


def _mesh_to_meshio(self):
    """This mesh as a meshio.Mesh (triangles; point data: vertex_area_um2)."""
    import meshio

    return meshio.Mesh(np.asarray(self.positions), [("triangle", np.asarray(self.faces))],
                       point_data={"vertex_area_um2": self.vertex_areas_um2()})


def mesh_from_meshio(m) -> Mesh:
    """A rbc.Mesh from a meshio.Mesh's points (um) and triangle cells."""
    tri = [c.data for c in m.cells if c.type == "triangle"]
    if not tri:
        raise ValueError("the meshio mesh has no triangle cells")
    return Mesh(np.asarray(m.points, dtype=float)[:, :3], np.concatenate(tri).astype(np.int32))


Mesh.to_meshio = _mesh_to_meshio

# ---- dynamics (rbc.dynamics: the scenes of `rbc dynamics`; python/rbc/_dynamics.py) ----
from ._dynamics import DynamicsResult, dynamics  # noqa: E402  (re-exported API)
# ---- end of dynamics ----

# Pictures of cells (numpy, h5py, meshio and matplotlib; the same script `rbc render` runs).
from .render import plot_shape, read_shapes  # noqa: E402  (re-exported API)

__all__ = [name for name in dir() if not name.startswith("_") and name not in (
    "annotations", "dataclasses", "enum", "math", "np", "Any", "Callable", "Optional",
    "Sequence")]


def __dir__():
    """The public API only (PEP 562): the helper modules imported above stay out of dir(rbc)."""
    return sorted(__all__)
