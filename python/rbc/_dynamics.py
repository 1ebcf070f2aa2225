# SPDX-License-Identifier: GPL-3.0-or-later
"""rbc.dynamics: the overdamped dynamics scenes of ``rbc dynamics`` (release, stretch, relax)
for either model, through the same library call, so the numbers are the CLI's bit for bit."""
from __future__ import annotations

import json
from typing import Callable, Optional

import numpy as np

from . import _rbc
from ._rbc import (BendingParameters, ConstraintParameters, ContactParameters, Order,
                   StericParameters, WlcParameters)


class DynamicsResult:
    """A trajectory of rbc.dynamics: per-sample numpy arrays and the summary of
    ``rbc dynamics --json``.

    Arrays (one entry per sample, read-only): ``time_s`` (s), ``axial_um`` (D_A, um),
    ``transverse_um`` (D_T, um), ``aspect_ratio`` (D_A/D_T), ``energy_pNum`` (free energy
    without the constraint terms, pN um), ``area_drift`` and ``volume_drift`` (relative),
    ``iterations`` (solver iterations since the previous sample); ``positions`` (samples, N, 3)
    in um and ``faces`` (F, 3). ``to_dict()`` is the JSON `rbc dynamics --json` prints (keys
    with units: ``recovery_time_s``, ``kelvin_voigt_time_s``, ``lambda_inf``, ``fluids``, ...;
    ``samples`` thinned to about 200)."""

    def __init__(self, model: str, scene: str, raw):
        self.model = model  #: 'discrete' or 'continuum'
        self.scene = scene  #: 'release', 'stretch' or 'relax'
        self._raw = raw
        self._summary = json.loads(raw.summary_json)
        self.time_s = raw.time_s
        self.axial_um = raw.axial_um
        self.transverse_um = raw.transverse_um
        self.energy_pNum = raw.energy_pNum
        self.area_drift = raw.area_drift
        self.volume_drift = raw.volume_drift
        self.iterations = raw.iterations
        self.vertices = raw.vertices  #: mesh vertices
        self.elements = raw.elements  #: continuum triangles (0 for the discrete model)
        self.law = raw.law  #: continuum in-plane law name ('' for the discrete model)
        self.halved_steps = raw.halved_steps  #: steps that needed halving
        self.wall_s = raw.wall_s  #: wall-clock time of the trajectory (s)

    @property
    def aspect_ratio(self) -> np.ndarray:
        """lambda = D_A/D_T per sample (Hochmuth's measure of the release)."""
        return self.axial_um / self.transverse_um

    @property
    def positions(self) -> np.ndarray:
        """(samples, N, 3) vertex positions (um) at every sample (a copy)."""
        return self._raw.positions

    @property
    def faces(self) -> np.ndarray:
        return self._raw.faces

    @property
    def recovery_time_s(self) -> Optional[float]:
        """Release: fitted recovery time t_c (s); None for the other scenes."""
        return self._summary.get("recovery_time_s")

    def to_dict(self) -> dict:
        """The JSON summary of ``rbc dynamics --json`` (a new dict on every call)."""
        return json.loads(self._raw.summary_json)

    def __repr__(self):
        s = self._summary
        text = (f"DynamicsResult(model={self.model!r}, scene={self.scene!r}, "
                f"{len(self.time_s)} samples over {s['duration_s']:g} s at dt {s['dt_s']:g} s, "
                f"D_A {self.axial_um[0]:.4g} -> {self.axial_um[-1]:.4g} um, "
                f"D_T {self.transverse_um[0]:.4g} -> {self.transverse_um[-1]:.4g} um")
        if "recovery_time_s" in s:
            text += f", recovery_time_s={s['recovery_time_s']:.4g}"
        if "disc_diameter_after_um" in s:
            text += f", disc_diameter_after_um={s['disc_diameter_after_um']:.4g}"
        return text + ")"


def dynamics(model: str = "continuum", scene: str = "release", *, scheme: str = "be",
             force_pN: float = 88.0, membrane_viscosity_pN_s_per_um: float = 0.7,
             dilatational_ratio: float = 2.0, duration_s: float = 0.5, dt_s: float = 1e-3,
             tolerance_pN_per_s: float = 0.0, normal_drag_pN_s_per_um3: float = 3.5e-3,
             regulariser: float = 0.01, vertices: int = 500, elements: int = 1000,
             order: "Order | str | int" = "2", max_halvings: int = 4, step_iterations: int = 0,
             wlc: Optional[WlcParameters] = None, bending: Optional[BendingParameters] = None,
             steric: Optional[StericParameters] = None,
             contact: Optional[ContactParameters] = None,
             constraints: Optional[ConstraintParameters] = None,
             cancel: Optional[Callable[[], bool]] = None,
             progress: Optional[Callable[[str], None]] = None) -> DynamicsResult:
    """Overdamped dynamics of either model, as ``rbc dynamics`` (same options, same numbers).

    model: 'discrete' (spectrin network of about `vertices` vertices, 100 to 40,000) or
    'continuum' (`elements` triangles, law of `order` 2, 3, 4 or 'full'). scene:
    'release' (the equilibrium at `force_pN`, then F = 0 from t = 0: the recovery of Hochmuth,
    Worthy & Evans 1979, with the fitted recovery time), 'stretch' (the rest shape, then
    `force_pN` from t = 0) or 'relax' (continuum only: the Helfrich relaxation at fixed area and
    volume, with the fluids' `normal_drag_pN_s_per_um3` and the in-plane `regulariser`, a
    fraction of the p = 2 law in (0, 1]).

    Time: steps of `dt_s` (s, in (0, duration_s]) to `duration_s` (s, > 0) by backward Euler
    (scheme 'be') or BDF2 ('bdf2', discrete only); a failing step is halved up to
    `max_halvings` times (0 to 20). Dissipation: membrane shear viscosity
    `membrane_viscosity_pN_s_per_um` (eta_m, pN s/um, > 0) and, continuum, the dilatational
    viscosity `dilatational_ratio` x eta_m (>= 0). Each step is solved to a force tolerance
    `tolerance_pN_per_s` x dt (pN/s; 0 = 1 for release and stretch, 1e-5 for relax) with
    `step_iterations` solver iterations (0 = the defaults: 20,000 L-BFGS iterations per
    multiplier update, discrete; 50 Newton iterations, continuum). `force_pN` (total bead force,
    pN): in (0, 500] discrete, (0, 400] continuum.

    wlc, bending, steric, contact, constraints: the physics (None = the paper's parameters, as
    the CLI's defaults), the objects rbc.Network takes.

    Every number must be finite and within the limits above: anything else raises ValueError
    naming the argument, its value and the limit, before any work. A static equilibrium or a
    time step that does not converge raises rbc.ConvergenceError (as the CLI exits 1). The GIL
    is released while solving; Ctrl-C, or `cancel()` returning True, stops the run with
    KeyboardInterrupt (polled before every step). `progress(message)` receives the library's
    progress lines.
    """
    from . import Model  # the package's enum ('discrete', 'continuum')

    model = Model.of(model).value
    raw = _rbc._dynamics(model, scene, scheme, force_pN, membrane_viscosity_pN_s_per_um,
                         dilatational_ratio, duration_s, dt_s, tolerance_pN_per_s,
                         normal_drag_pN_s_per_um3, regulariser, vertices, elements, order,
                         max_halvings, step_iterations, wlc, bending, steric, contact,
                         constraints, cancel, progress)
    return DynamicsResult(model, scene, raw)
