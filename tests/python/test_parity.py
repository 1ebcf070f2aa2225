# SPDX-License-Identifier: GPL-3.0-or-later
"""The package as a user first meets it: a single force where a list is expected, short
representations of results, and a namespace that shows the API alone."""
import numpy as np
import pytest

import rbc


def test_one_force_is_accepted_where_a_list_is_expected():
    one = rbc.stretch("continuum", 38, elements=200)
    listed = rbc.stretch("continuum", [38.0], elements=200)
    assert len(one) == 1 and one.forces_pN.tolist() == [38.0]
    assert one.axial_um.tolist() == listed.axial_um.tolist()  # the same solve, bit for bit
    with pytest.raises(ValueError, match="forces_pN: expected a force or a list of forces"):
        rbc.stretch("continuum", [[0.0, 38.0]], elements=200)


def test_representations_are_short_and_name_the_result():
    result = rbc.stretch("discrete", [0, 38], vertices=300)
    text = repr(result)
    assert len(text) < 200 and "discrete" in text and "38.0" in text
    point = repr(result[1])
    # The arrays are summarised by their shape, not printed.
    assert len(point) < 300 and f"({result[1].vertices}, 3)" in point
    assert f"axial_um={result[1].axial_um:.4f}" in point


def test_dir_shows_the_api_and_not_the_modules_the_package_uses():
    names = dir(rbc)
    for helper in ("np", "math", "enum", "dataclasses", "Optional", "Sequence", "Any",
                   "Callable", "annotations"):
        assert helper not in names
    for api in ("stretch", "moduli", "Network", "plot_shape", "infer", "DEFAULT_FORCES_PN"):
        assert api in names
    assert names == sorted(rbc.__all__)
    assert np.all([not n.startswith("_") for n in names])
