"""SPACAR mode 10 (analysis ``static_linearized``): the static path with, at every step, the
linearized equations of mode 9 (/state_space), the frequencies and the buckling multipliers.

On decks/state_space_cantilever.dat (a preloaded cantilever, so the matrices change from
step to step): the matrices mode 10 stores at every step are the mode-9 matrices of the same
deck at the same step; the poles of A at each step are +-i 2 pi f of the frequencies mode 10
stores at that step; without INPUTF/OUT* lines the same M0, C0, K0 and A are stored with
empty B, C, D; ``MODE static`` stays the plain static path; a model without mass stores no
/state_space and says why.
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from spacarpy.deck import job_from_text, load
from spacarpy.results import open_results, validate_file
from spacarpy.run import run_model

DECK = Path(__file__).resolve().parents[1] / "decks" / "state_space_cantilever.dat"
NAMES = ("M0", "C0", "K0", "B0", "A", "B", "C", "D")


def _run(tmp_path_factory, name, text=None, analysis=None, **kw):
    out = tmp_path_factory.mktemp(name) / f"{name}.h5"
    job = load(DECK) if text is None else job_from_text(text, f"{name}.dat")
    settings = job.settings if analysis is None else job.settings.override(analysis=analysis,
                                                                            **kw)
    run_model(job.model, settings, out)
    return out


@pytest.fixture(scope="module")
def mode9(tmp_path_factory):
    return _run(tmp_path_factory, "m9", analysis="9")


@pytest.fixture(scope="module")
def mode10(tmp_path_factory):
    return _run(tmp_path_factory, "m10", analysis="10", n_modes=24)


def test_mode_10_stores_the_mode_9_matrices_at_every_step(mode9, mode10):
    assert validate_file(mode10, require_complete=True) == []
    with open_results(mode9) as r9, open_results(mode10) as r10:
        assert r10.analysis == "static_linearized"
        assert r10.state_space.step.tolist() == [0, 1, 2] == r9.state_space.step.tolist()
        assert r10.state_space.input_name == r9.state_space.input_name
        assert r10.state_space.output_name == r9.state_space.output_name
        k0 = []
        for step in (0, 1, 2):
            m9 = {n: r9.state_space.matrix(n, step) for n in NAMES}
            m10 = {n: r10.state_space.matrix(n, step) for n in NAMES}
            for name in NAMES:
                scale = max(np.abs(m9[name]).max(initial=0.0), 1e-300)
                np.testing.assert_allclose(m10[name], m9[name], rtol=0,
                                           atol=1e-12 * scale, err_msg=f"{name} step {step}")
            k0.append(m10["K0"])
    # the preload is in it: the stiffness changes along the path (not one matrix three times)
    change = np.abs(k0[2] - k0[0]).max() / np.abs(k0[0]).max()
    assert change > 1e-6          # 2e-5 here (the axial entries dominate the max)


@pytest.mark.parametrize("step", [0, 1, 2])
def test_poles_are_the_stored_frequencies_at_every_step(mode10, step):
    with open_results(mode10) as res:
        A = res.state_space.matrix("A", step)
        f = res.eigen.frequency[res.eigen.row(step)]
        assert res.eigen.step.tolist() == [0, 1, 2]
        assert res.buckling.step.tolist() == [0, 1, 2]
    assert f.size == 24 and np.all(np.isfinite(f))
    poles = np.linalg.eigvals(A)
    np.testing.assert_allclose(poles.real, 0.0, atol=1e-6 * np.abs(poles).max())
    up = np.sort(poles.imag[poles.imag > 0])
    np.testing.assert_allclose(up, 2 * np.pi * np.sort(f), rtol=1e-8)


def _without_signals():
    text = DECK.read_text()
    return re.sub(r"^(INPUTF|OUTX|OUTXP|OUTE|OUTEP)\b.*$", "", text, flags=re.M)


def test_without_signals_the_matrices_are_stored(tmp_path_factory, mode10):
    """No INPUTF/OUT* lines: M0, C0, K0 and A as before; B0, B have no columns, C no rows."""
    out = _run(tmp_path_factory, "nosig", text=_without_signals(), analysis="10")
    assert validate_file(out, require_complete=True) == []
    with open_results(out) as res, open_results(mode10) as full:
        for step in (0, 2):
            m = {n: res.state_space.matrix(n, step) for n in NAMES}
            ref = {n: full.state_space.matrix(n, step) for n in NAMES}
            assert m["B0"].shape == (24, 0) and m["B"].shape == (48, 0)
            assert m["C"].shape == (0, 48) and m["D"].shape == (0, 0)
            for name in ("M0", "C0", "K0", "A"):
                np.testing.assert_allclose(m[name], ref[name], rtol=0,
                                           atol=1e-12 * np.abs(ref[name]).max())


def test_mode_static_stays_plain(tmp_path_factory):
    out = _run(tmp_path_factory, "plain", text=_without_signals(), analysis="static")
    with open_results(out) as res:
        assert res.analysis == "static"
        assert res.state_space is None and res.eigen is None


def test_mode_10_without_mass_says_why(tmp_path_factory, caplog, mode10):
    """No mass: a warning, no /state_space, and the buckling multipliers of every step are
    those of the model with mass (they do not depend on it)."""
    text = re.sub(r"^EM .*$", "", _without_signals(), flags=re.M)
    with caplog.at_level("WARNING"):
        out = _run(tmp_path_factory, "nomass", text=text, analysis="-10")
    assert "SPACAR mode 10 stores the linearized equations (/state_space) only for a model " \
           "with mass" in caplog.text
    assert validate_file(out, require_complete=True) == []
    with open_results(out) as res:
        assert res.state_space is None and res.eigen is None
        assert res.buckling.step.tolist() == [0, 1, 2]
        crit = res.buckling.critical_load_multiplier
    with open_results(mode10) as full:
        ref = full.buckling.critical_load_multiplier
    assert np.isfinite(ref[1:]).all() and 1 < ref[-1] < ref[1]   # 8.19, then 4.10
    np.testing.assert_allclose(crit, ref, rtol=1e-9)
