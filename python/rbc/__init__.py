# SPDX-License-Identifier: GPL-3.0-or-later
"""rbc: multiscale red blood cell membrane mechanics (Hartmann 2008) from Python.

The compiled core (``rbc._rbc``, pybind11) binds the C++ libraries directly -- not the ``rbc``
executable -- so the numbers are the CLI's for the same inputs. Units are in the names:
lengths in um, forces in pN, energies in pN um inside; physical inputs in natural units
(``persistence_nm``, ``kappa_J``, ``wlc_temperature_K``), converted once. Positions are
``(N, 3)`` float64 arrays in um, faces ``(F, 3)`` int32. The shared physics (the CLI's option
group of --lbar, --lmax, --persistence, --temperature, --kappa, --h0, --q, --eta, --contact,
--contact-fraction, --bending, --dihedral-mapping) is one object, rbc.ModelParameters.

Every key of every dict the package returns names its unit (``mu_closed_pN_per_um``,
``energy_pNum``, ``wall_s``) or is listed in rbc.UNITLESS_KEYS (dimensionless numbers, counts,
flags, text and groups of other keys); a dict with a ``"unit"`` entry holds numbers in that unit,
and the dicts under a key with a unit (``"energy_pNum": {"mean": ..., "error": ...}``) are in
that key's unit.

Long solves release the GIL (Python threads can run several at once) and poll Ctrl-C: a
KeyboardInterrupt cancels them. Process pools must use the ``spawn`` start method once OpenMP
has run in the parent (``multiprocessing.get_context("spawn")``): a forked child inherits
OpenMP's thread pool in an unusable state and can hang.

Example::

    import rbc
    res = rbc.stretch("discrete", forces_pN=[0, 88], vertices=500,
                      parameters=rbc.ModelParameters(persistence_nm=10))
    print(res.axial_um, res.transverse_um)       # D_A, D_T per force (um)
    net = rbc.Network(rbc.rest_shape(500))
    e, g = rbc.network_energy(net, net.rest_positions, force_pN=88.0)
"""
from __future__ import annotations

import dataclasses
import enum
import math
import numbers
from typing import TYPE_CHECKING, Any, Callable, Optional, Sequence

import numpy as np

if TYPE_CHECKING:  # the annotations' types; imported where they are used
    import meshio
    import scipy.sparse
    import scipy.sparse.linalg

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
    network_energy,
    network_energy_parts,
    rest_shape,
    thermal_energy_pNum,
)

#: The version of the compiled core, as `rbc --version` prints it (e.g. "0.1.0+g5a3eb55").
__version__ = _rbc.__version__

#: The forces of `rbc stretch` (pN): those of Mills et al. 2004.
DEFAULT_FORCES_PN = (0.0, 16.0, 19.5, 30.6, 38.0, 46.6, 67.6, 87.6, 108.8, 130.0, 151.0, 172.8,
                     193.0)


#: The keys of the package's dicts that carry no unit suffix, because they are dimensionless
#: numbers (ratios, relative drifts, invariants, exponents, probabilities, log-likelihoods),
#: counts, seeds, flags, text, or the names of groups of other keys. Every other key ends in its
#: unit: _um, _um2, _um3, _nm, _pN, _pNum (pN um), _J, _K, _s, _per_um, _pN_per_um (= uN/m),
#: _uN_per_m, _pN_per_um2 ... (tests/python/test_units.py checks every returned dict).
UNITLESS_KEYS = frozenset({
    # dimensionless numbers
    "I1", "I2", "poisson", "poisson_closed", "poisson_std", "mu_relative_difference",
    "K_relative_difference", "max_internal_displacement_over_lbar",
    "relaxation_start_amplitude_over_lbar", "psi_patch_over_lattice_minus_1", "disorder",
    "degree6_fraction", "degree6_fraction_std", "phi_over_area", "row_distortion",
    "area_drift", "volume_drift", "max_area_drift", "max_volume_drift", "worst_aspect_ratio",
    "volume_scale", "penalty_scale", "acceptance", "beta", "cov", "distinct_parents",
    "unique_fraction", "log_mean_weight", "log_evidence", "log_evidence_sd",
    "log_likelihood_samples", "inefficiency", "q", "eta", "contact_fraction",
    "strain", "mu_relative_shift", "mu_relative_shift_error", "K_relative_shift",
    "K_relative_shift_error", "equipartition_ratio", "equipartition_ratio_error",
    # counts, seeds and indices
    "cells", "rows", "vertices", "edges", "faces", "elements", "seeds", "seed", "streams",
    "samples", "samples_per_stage", "discarded_transient", "sweep", "sweeps", "adaptive_sweeps",
    "warmup_sweeps", "batches", "chains", "chain_seeds", "chain_steps", "chain_sweeps",
    "samples_per_chain", "rhat_threshold",
    "colours", "iterations", "newton_iterations", "phi_iterations", "degree_histogram", "stage",
    "stages", "forward_runs", "made", "retried", "failed", "threads", "ranks",
    "resumed_from_stage", "symmetry_order", "used", "requested",
    # flags and text
    "converged", "blocking_converged", "symmetry_broken", "transverse_used", "network", "law",
    "status", "status_text", "method", "data_file", "command", "unit", "library", "core",
    "config", "bending", "contact", "dihedral_mapping", "log_evidence_error_estimate", "reason",
    "file", "name", "sigma", "sampler", "mass_matrix", "rhat_method", "stem", "kind", "contents",
    # HMC: dimensionless trajectory time, counts; where the mass matrix was built (text) and
    # the count of transitions its thermal mean averaged; how area and volume are held (text)
    # and the counts of constrained steps that failed
    "trajectory_time", "evaluations", "solves", "factor_nonzeros", "mass_reference",
    "mass_built_at", "mass_reference_transitions", "area_volume", "constraint_failed_solves",
    "constraint_failed_reverse_checks",
    # groups of other keys (their entries carry the units)
    "parameters", "derived", "timing", "stage_log", "stage_info", "data", "data_sets",
    "predictive_q05_q50_q95", "hmc", "per_chain",
    # rbc infer --predict: "predictions" (calibrate/predictive.hpp, recovery_prediction.hpp);
    # recovery data are lengths over widths (dimensionless) and their normalised recovery
    "predictions", "path", "draws", "used_draws", "trajectories", "failed_forward_runs",
    "failed_trajectories", "failed_nuisance_fits", "quantiles", "points", "coverage", "all",
    "axial", "transverse", "inside_50", "inside_90", "band_50", "band_90", "cell", "observed",
    "q05", "q25", "q50", "q75", "q95", "length_over_width", "normalised_recovery", "lambda_0",
    "lambda_inf", "sigma_ratio", "eta_m_inferred", "eta_m_source", "nuisances",
})
# "samples" of rbc.infer() is (S, P): each column in the unit of InferenceProblem.units.


_MODEL_DEFAULTS = _rbc._model_defaults()


@dataclasses.dataclass(frozen=True)
class ModelParameters:
    """The physics every model shares, in natural units: the CLI's option group "Model"
    (--lbar, --lmax, --persistence, --temperature, --kappa, --h0, --q, --eta, --contact,
    --contact-fraction, --bending, --dihedral-mapping) with the same defaults
    (core/defaults.hpp: Li et al. 2005 / paper Tables 1 and 2).

    lbar_nm: spectrin rest link length Lbar (nm); lmax_nm: contour length Lmax (nm, > Lbar);
    persistence_nm: persistence length p (nm); temperature_K: temperature of the WLC links (K;
    a Monte Carlo chain samples at its own sampling_temperature_K); kappa_J: bending rigidity
    (J); h0_per_um: spontaneous curvature H0 (1/um); q, eta: steric exponent and regularisation
    (dimensionless); contact: bead contact rule, "area" or "vertices"; contact_fraction: patch
    fraction per bead (dimensionless, of the area or of the vertices); bending: "juelicher" or
    "dihedral" (discrete model); dihedral_mapping: k_b(kappa) of the dihedral model, "sphere"
    or "li".

    Immutable (dataclasses.replace(p, q=2) gives a changed copy). The values are checked when
    the object is made, by the libraries' validate(): a non-physical value raises ValueError
    naming it and its limit. rbc.stretch, rbc.Network, rbc.moduli and rbc.psi take it as
    ``parameters=``; .wlc_parameters, .bending_parameters, .steric_parameters and
    .contact_parameters are the per-term objects (rbc.WlcParameters, ...) they convert to.
    """

    lbar_nm: float = _MODEL_DEFAULTS["lbar_nm"]
    lmax_nm: float = _MODEL_DEFAULTS["lmax_nm"]
    persistence_nm: float = _MODEL_DEFAULTS["persistence_nm"]
    temperature_K: float = _MODEL_DEFAULTS["temperature_K"]
    kappa_J: float = _MODEL_DEFAULTS["kappa_J"]
    h0_per_um: float = _MODEL_DEFAULTS["h0_per_um"]
    q: float = _MODEL_DEFAULTS["q"]
    eta: float = _MODEL_DEFAULTS["eta"]
    contact: str = _MODEL_DEFAULTS["contact"]
    contact_fraction: float = _MODEL_DEFAULTS["contact_fraction"]
    bending: str = _MODEL_DEFAULTS["bending"]
    dihedral_mapping: str = _MODEL_DEFAULTS["dihedral_mapping"]

    def __post_init__(self):
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if f.type == "str" and not isinstance(v, str):
                raise TypeError(f"ModelParameters({f.name}={v!r}): expected a str")
            if f.type == "float":
                if isinstance(v, (bool, str)) or not isinstance(v, numbers.Real):
                    raise TypeError(f"ModelParameters({f.name}={v!r}): expected a number")
                object.__setattr__(self, f.name, float(v))
        objects = _rbc._model_objects(**dataclasses.asdict(self))
        object.__setattr__(self, "_objects", objects)

    @property
    def wlc_parameters(self) -> WlcParameters:
        """The spectrin WLC term (lbar_nm, lmax_nm, persistence_nm, temperature_K)."""
        return self._objects[0]

    @property
    def bending_parameters(self) -> BendingParameters:
        """The bending term (kappa_J, h0_per_um, bending, dihedral_mapping)."""
        return self._objects[1]

    @property
    def steric_parameters(self) -> StericParameters:
        """The steric face term (q, eta)."""
        return self._objects[2]

    @property
    def contact_parameters(self) -> ContactParameters:
        """The bead contact (contact, contact_fraction)."""
        return self._objects[3]

    def to_dict(self) -> dict:
        """The fields as a dict (keys as the attributes: units in the names)."""
        return dataclasses.asdict(self)

    def __getstate__(self):
        return dataclasses.asdict(self)

    def __setstate__(self, state):
        for k, v in state.items():
            object.__setattr__(self, k, v)
        self.__post_init__()


def _physics(parameters: Optional[ModelParameters], wlc, bending, steric, contact):
    """The per-term objects from `parameters` or from the separate keyword arguments."""
    if parameters is None:
        return wlc, bending, steric, contact
    if not isinstance(parameters, ModelParameters):
        raise TypeError(f"parameters must be an rbc.ModelParameters, got {parameters!r}")
    given = [n for n, v in (("wlc", wlc), ("bending", bending), ("steric", steric),
                            ("contact", contact)) if v is not None]
    if given:
        raise ValueError(f"give either parameters (rbc.ModelParameters) or {', '.join(given)}, "
                         "not both")
    return (parameters.wlc_parameters, parameters.bending_parameters,
            parameters.steric_parameters, parameters.contact_parameters)


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
            parameters: Optional[ModelParameters] = None,
            wlc: Optional[WlcParameters] = None, bending: Optional[BendingParameters] = None,
            steric: Optional[StericParameters] = None, contact: Optional[ContactParameters] = None,
            constraints: Optional[ConstraintParameters] = None,
            mesh_quality: "MeshQuality | str" = "phi-minimised",
            mesh_orientation: str = "dimple-vertex", network: Optional[Network] = None,
            tolerance_pN: Optional[float] = None, max_iterations: Optional[int] = None,
            symmetry: str = "none", check: bool = False,
            cancel: Optional[Callable[[], bool]] = None,
            progress: Optional[Callable[[str], None]] = None) -> StretchResult:
    """Optical-tweezers stretch by continuation over forces_pN (pN), as ``rbc stretch``.

    The physics: `parameters` (an rbc.ModelParameters: the CLI's shared options in natural
    units), or the per-term objects wlc, bending, steric, contact (not both); None = the
    CLI's defaults. constraints: the area/volume penalties (pN/um^3, pN/um^5).

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
    if parameters is not None and network is not None:
        raise ValueError("give either network or parameters, not both (the network carries its "
                         "parameters: rbc.Network(mesh, parameters=...))")
    wlc, bending, steric, contact = _physics(parameters, wlc, bending, steric, contact)
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


def network_hessian(network: Network, positions: np.ndarray, *,
                    area_multiplier_pN_per_um: float = 0.0,
                    volume_multiplier_pN_per_um2: float = 0.0, stiffness_scale: float = 1.0,
                    exact: bool = True, penalty: bool = False,
                    shift_fraction: float = 0.0) -> "scipy.sparse.csr_matrix":
    """Hessian (pN/um) of rbc.network_energy at `positions` as a scipy.sparse CSR matrix of
    size 3N x 3N, ordered like the flat positions (x0, y0, z0, x1, ...). positions: (N, 3)
    or (3N,) in um; the multipliers lambda_A (pN/um) and lambda_V (pN/um^2) and the penalty
    scale (dimensionless) as for rbc.network_energy; shift_fraction (dimensionless) shifts the
    projected matrix's diagonal.

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
        a = d["area_gradient_um"].reshape(-1)
        v = d["volume_gradient_um2"].reshape(-1)
        dense = (d["area_weight_pN_per_um3"] * np.outer(a, a)
                 + d["volume_weight_pN_per_um5"] * np.outer(v, v))
        h = scipy.sparse.csr_matrix(h + dense)
    return h


def network_hessian_operator(network: Network, positions: np.ndarray, *,
                             area_multiplier_pN_per_um: float = 0.0,
                             volume_multiplier_pN_per_um2: float = 0.0,
                             stiffness_scale: float = 1.0,
                             exact: bool = True) -> "scipy.sparse.linalg.LinearOperator":
    """The full Hessian (pN/um; sparse part + the penalty's rank-two part) as a
    scipy.sparse.linalg.LinearOperator, for Newton-CG / trust-region solvers at any N
    (arguments as network_hessian's)."""
    from scipy.sparse.linalg import LinearOperator

    d = _rbc._network_hessian(network, positions, area_multiplier_pN_per_um,
                              volume_multiplier_pN_per_um2, stiffness_scale, exact, 0.0)
    import scipy.sparse

    n = d["size"]
    h = scipy.sparse.csr_matrix((d["data"], d["indices"], d["indptr"]), shape=(n, n))
    a = d["area_gradient_um"].reshape(-1)
    v = d["volume_gradient_um2"].reshape(-1)
    wa, wv = d["area_weight_pN_per_um3"], d["volume_weight_pN_per_um5"]

    def matvec(x):
        x = np.asarray(x).reshape(-1)
        return h @ x + wa * a * (a @ x) + wv * v * (v @ x)

    return LinearOperator((n, n), matvec=matvec, rmatvec=matvec, dtype=float)


def infer(problem: Optional[InferenceProblem] = None, *,
          cancel: Optional[Callable[[], bool]] = None,
          progress: Optional[Callable[[str], None]] = None, predict: Sequence[str] = (),
          predict_draws: Optional[int] = None, predict_recovery_draws: Optional[int] = None,
          **options: Any) -> dict:
    """Bayesian calibration as ``rbc infer``: the posterior of the inferred parameters given
    force-diameter data (MODEL.md section 7), by laplace-is (the default) or TMCMC.

    Pass an rbc.InferenceProblem, or its keyword arguments (parameters=['persistence', 'lmax',
    'sigma-scale'], priors={name: (lower, upper)}, method='continuum:2:2000', data_file,
    sampler='laplace-is' with is_samples=1000 and is_rounds=4, or sampler='tmcmc' with
    samples=500, seed=1, ...;
    the CLI's defaults). Returns the fields of ``rbc infer --json``
    (each parameter's and each derived modulus's summary is a dict with its "unit") plus
    'samples' (S, P; column j in the unit InferenceProblem.units[j]: nm, J or dimensionless),
    'log_likelihood_samples' (dimensionless), the derived 'mu_samples_uN_per_m' and
    'K_samples_uN_per_m' (S,), and 'stage_info' (per TMCMC stage, one for laplace-is: stage,
    beta, cov, log_mean_weight, acceptance, unique_fraction, forward_runs; all dimensionless).
    The GIL is released; Ctrl-C or cancel() returning True stops between stages with
    KeyboardInterrupt.

    predict: held-out data files, as ``rbc infer --predict``: 'predictions' then holds, per
    stretch file, the 5, 25, 50, 75 and 95 % quantiles of D_A, D_T (um) with the file's own
    error bars and the fraction of its points inside the 50 % and 90 % bands; per recovery file
    (header cell,time_s,length_over_width; kind "recovery") each cell's predicted length over
    width (dimensionless) with its bands and coverage. predict_draws and
    predict_recovery_draws as ``--predict-draws`` and ``--predict-recovery-draws`` (None: their
    defaults; 0: every sample).
    """
    if problem is None:
        problem = InferenceProblem(**options)
    elif options:
        raise ValueError("give either an InferenceProblem or its options, not both")
    extra = {} if predict_draws is None else {"predict_draws": predict_draws}
    if predict_recovery_draws is not None:
        extra["predict_recovery_draws"] = predict_recovery_draws
    return _rbc._infer(problem, cancel, progress, predict=[str(p) for p in predict], **extra)


def moduli(*, parameters: Optional[ModelParameters] = None,
           wlc: Optional[WlcParameters] = None, steric: Optional[StericParameters] = None,
           network: str = "hex", cells: int = 0, disorder: float = 0.5, seeds: int = 4,
           cancel: Optional[Callable[[], bool]] = None,
           progress: Optional[Callable[[str], None]] = None) -> dict:
    """Linear moduli of the spectrin network: the keys of ``rbc moduli --json`` without its
    run record (command, config, provenance) and wall_s.

    The physics: `parameters` (rbc.ModelParameters; its WLC and steric fields count), or wlc
    and steric (not both); None = the CLI's defaults. network 'hex': the periodic hexagonal
    patch of `cells` x `cells` cells (0 = 4); 'disordered': `seeds` disordered networks of
    `cells` (0 = 12) with disorder X = `disorder` in [0, 1].

    Keys: moduli and tensions in pN/um (= uN/m): mu_closed_pN_per_um, K_closed_pN_per_um,
    young_closed_pN_per_um (closed forms, Sec. 4.3), mu_paper_formula_pN_per_um,
    K_paper_formula_pN_per_um (the paper's explicit formulas), steric_C_pN_per_um (the steric
    constant C), mu_numeric_pN_per_um, K_numeric_pN_per_um, young_pN_per_um (the numerical cell
    problem; disordered: means over the seeds, with ``*_std_pN_per_um``, and the affine
    mu_affine_pN_per_um, K_affine_pN_per_um, the residual prestress_pN_per_um); lengths
    max_internal_displacement_um; residual_pN / worst_residual_pN. Dimensionless (see
    rbc.UNITLESS_KEYS): poisson_closed, poisson, ``*_relative_difference``, ``*_over_lbar``,
    psi_patch_over_lattice_minus_1, degree6_fraction, phi_over_area, disorder, row_distortion;
    counts cells, rows, vertices, seeds, newton_iterations; converged; network.
    """
    wlc, _, steric, _ = _physics(parameters, wlc, None, steric, None)
    return _rbc.moduli(wlc=wlc, steric=steric, network=network, cells=cells, disorder=disorder,
                       seeds=seeds, cancel=cancel, progress=progress)


def thermal_moduli(sampling_temperature_K: float, *,
                   parameters: Optional[ModelParameters] = None,
                   wlc: Optional[WlcParameters] = None, steric: Optional[StericParameters] = None,
                   network: str = "hex", cells: int = 0, disorder: float = 0.5,
                   sweeps: int = 20000, warmup_sweeps: int = 2000, strain: float = 0.005,
                   batches: int = 20, seed: int = 1,
                   cancel: Optional[Callable[[], bool]] = None,
                   progress: Optional[Callable[[str], None]] = None) -> dict:
    """Isothermal shear and area moduli of the periodic spectrin cell sampled at
    `sampling_temperature_K` (K) beside the zero-temperature Gamma limit: the keys of
    ``rbc moduli --sampling-temperature T --json`` without its run record and wall_s.

    The physics as for rbc.moduli (the WLC constants keep their own temperature). network
    'hex': the hexagonal patch of `cells` x `cells` (0 = 10); 'disordered': the disordered
    network of seed 1 with `cells` columns (0 = 12) and disorder `disorder`. Local Metropolis,
    `warmup_sweeps` to adapt the step, then `sweeps` per chain at the strains +-`strain` of the
    two pure shears and the area stretch; errors from `batches` batch means; `seed` fixes the
    result whatever the thread count.

    Keys: mu_pN_per_um, K_pN_per_um and their ``*_error_pN_per_um``; the Gamma limit
    mu_gamma_pN_per_um, K_gamma_pN_per_um; the quasi-harmonic O(T) prediction
    ``*_quasi_harmonic_pN_per_um``; the relative shifts mu_relative_shift, K_relative_shift
    (dimensionless, with errors); the isotropic tension at F = I, tension_pN_per_um; the
    equipartition_ratio (mean energy per degree of freedom over k_B T / 2).
    """
    wlc, _, steric, _ = _physics(parameters, wlc, None, steric, None)
    return _rbc.thermal_moduli(sampling_temperature=sampling_temperature_K, wlc=wlc,
                               steric=steric, network=network, cells=cells, disorder=disorder,
                               sweeps=sweeps, warmup_sweeps=warmup_sweeps, strain=strain,
                               batches=batches, seed=seed, cancel=cancel, progress=progress)


def psi(order: "Order | str | int", deformation: "np.ndarray | Sequence", *,
        parameters: Optional[ModelParameters] = None, wlc: Optional[WlcParameters] = None,
        steric: Optional[StericParameters] = None) -> dict:
    """Homogenised density Psi of the given order (2, 3, 4 or 'full') at a 2x2 surface
    deformation gradient F (dimensionless; or a stack (M, 2, 2)): the keys of
    ``rbc psi --deformation F11,F12,F21,F22 --json`` without its run record.

    The physics: `parameters` (rbc.ModelParameters; its WLC and steric fields count), or wlc
    and steric (not both); None = the CLI's defaults.

    Keys (scalars for one F, arrays of length M for a stack): psi_pN_per_um (Psi, pN/um =
    energy per reference area), I1 = J - 1 and I2 = tr(F^T F) - 2 (dimensionless),
    dpsi_dI1_pN_per_um, dpsi_dI2_pN_per_um, first_piola_pN_per_um (P = dPsi/dF, (2, 2) or
    (M, 2, 2)), psi_lattice_pN_per_um (the un-averaged lattice density at phi = 0) and law (its
    name). Psi is inf outside the law's domain.
    """
    wlc, _, steric, _ = _physics(parameters, wlc, None, steric, None)
    return _rbc.psi(order, deformation, wlc=wlc, steric=steric)


def _mesh_to_meshio(self):
    """This mesh as a meshio.Mesh (triangles; point data: vertex_area_um2)."""
    import meshio

    return meshio.Mesh(np.asarray(self.positions), [("triangle", np.asarray(self.faces))],
                       point_data={"vertex_area_um2": self.vertex_areas_um2()})


def mesh_from_meshio(m: "meshio.Mesh") -> Mesh:
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
    "annotations", "dataclasses", "enum", "math", "numbers", "np", "TYPE_CHECKING", "Any",
    "Callable", "Optional", "Sequence")]


def __dir__():
    """The public API only (PEP 562): the helper modules imported above stay out of dir(rbc)."""
    return sorted(__all__)
