# SPDX-License-Identifier: GPL-3.0-or-later
"""The GIL is released during solves: two Python threads solving at once give the results of one
after the other; spawn process pools work after OpenMP has run; Ctrl-C (KeyboardInterrupt) and a
cancel callback stop long work through the library's cancel hook."""
import _thread
import multiprocessing
import threading

import numpy as np
import pytest

import rbc


def discrete_case(persistence_nm):
    """A small stretch (module-level, so spawn workers can import it)."""
    r = rbc.stretch("discrete", [0, 60], vertices=200,
                    wlc=rbc.WlcParameters(persistence_nm=persistence_nm))
    return [(p.axial_um, p.transverse_um, p.energy_pNum, p.iterations) for p in r]


def continuum_case(elements):
    r = rbc.stretch("continuum", [0, 60], elements=elements)
    return [(p.axial_um, p.transverse_um, p.energy_pNum, p.iterations) for p in r]


def test_two_threads_at_once_equal_one_after_the_other():
    cases = [(discrete_case, 7.5), (continuum_case, 600)]
    sequential = [f(a) for f, a in cases]
    results = [None, None]
    started = threading.Barrier(2)

    def work(i):
        started.wait()
        f, a = cases[i]
        results[i] = f(a)

    threads = [threading.Thread(target=work, args=(i,)) for i in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert results == sequential


def test_spawn_process_pool_after_openmp_has_run():
    parent = discrete_case(7.5)  # OpenMP has now run in this process
    ctx = multiprocessing.get_context("spawn")
    with ctx.Pool(2) as pool:
        children = pool.map(discrete_case, [7.5, 9.0])
    assert children[0] == parent
    assert children[1] != parent  # a different persistence length gives a different cell


def test_ctrl_c_interrupts_a_monte_carlo_run(small_network):
    mc = rbc.MonteCarlo(small_network, force_pN=0.0, seed=2, adapt_sweeps=0)
    timer = threading.Timer(0.5, _thread.interrupt_main)  # as Ctrl-C: SIGINT's Python handler
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            mc.run(10**8)
    finally:
        timer.cancel()
    done = mc.sweeps_done
    assert 0 < done < 10**8
    # the chain stopped at a sweep boundary and continues from there
    mc.run(3)
    assert mc.sweeps_done == done + 3


def test_cancel_callback_stops_a_stretch():
    calls = []

    def cancel():
        calls.append(1)
        return len(calls) >= 3

    with pytest.raises(KeyboardInterrupt):
        rbc.stretch("discrete", [0, 88, 193], vertices=300, cancel=cancel)
    assert len(calls) == 3  # polled by the solver, stopped at the first True


def test_cancel_callback_stops_a_monte_carlo_run(small_network):
    mc = rbc.MonteCarlo(small_network, adapt_sweeps=0)
    n = []
    with pytest.raises(KeyboardInterrupt):
        mc.run(1000, cancel=lambda: n.append(1) or len(n) > 5)
    assert mc.sweeps_done == 6  # polled after every sweep: the poll after sweep 6 cancelled


def test_an_exception_in_the_cancel_callback_propagates(small_network):
    mc = rbc.MonteCarlo(small_network, adapt_sweeps=0)

    def boom():
        raise ZeroDivisionError("from the callback")

    with pytest.raises(ZeroDivisionError, match="from the callback"):
        mc.run(10, cancel=boom)
