# SPDX-License-Identifier: GPL-3.0-or-later
"""rbc.thermal_moduli computes what `rbc moduli --sampling-temperature T --json` computes (exact comparison of every
key but the run record and the timing), and refuses bad input with a ValueError."""
import pytest

import rbc
from conftest import run_cli_json


def test_thermal_moduli_equal_the_cli():
    cli = run_cli_json("moduli", "--sampling-temperature", "200", "--cells", "4", "--sweeps",
                       "200", "--warmup-sweeps", "50", "--seed", "5", "--json", "-q")
    py = rbc.thermal_moduli(200, cells=4, sweeps=200, warmup_sweeps=50, seed=5)
    assert set(cli) - set(py) == {"wall_s", "command", "config", "provenance"}
    for k in sorted(py):
        assert py[k] == cli[k], f"{k}: python {py[k]!r} != cli {cli[k]!r}"
    # The hexagonal patch's Gamma limit is the closed form (Theorem 3).
    assert py["mu_gamma_pN_per_um"] == pytest.approx(py["mu_closed_pN_per_um"], rel=1e-9)


@pytest.mark.parametrize("kwargs", [dict(sampling_temperature_K=-1),
                                    dict(sampling_temperature_K=300, strain=0),
                                    dict(sampling_temperature_K=300, sweeps=10),
                                    dict(sampling_temperature_K=300, cells=2),
                                    dict(sampling_temperature_K=300, network="square")])
def test_thermal_moduli_refuse_bad_input(kwargs):
    with pytest.raises(ValueError):
        rbc.thermal_moduli(**kwargs)
