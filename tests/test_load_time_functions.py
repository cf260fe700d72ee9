"""A time function per load (issue 37): named TIMEFUNCTION lines and LOADTF. A load or motion
that names a function behaves exactly (bit for bit) as under the deck's unnamed function of
that kind; two loads with different functions superpose in the linear range; the deck
errors."""
from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest

from spacarpy.cli import main
from spacarpy.deck import job_from_text, model_from_text
from spacarpy.errors import DeckError

DECKS = Path(__file__).resolve().parents[1] / "decks"


def run(tmp_path, text: str, name: str) -> dict:
    deck = tmp_path / f"{name}.dat"
    deck.write_text(text)
    out = tmp_path / f"{name}.h5"
    assert main(["run", str(deck), "-o", str(out), "-q"]) == 0
    with h5py.File(out, "r") as f:
        return {k: f[f"transient/{k}"][:] for k in ("position", "euler", "time")}


def _cantilever(a: float, b: float, named: bool = True) -> str:
    """A 4-element cantilever (L = EI = rhoA = 1): a tip force a along y following
    ``pulse`` (sine 3 Hz) and a linear line load along y, b at the root to 2b at the tip,
    following ``slow`` (smoothstep over 0.2 s); the deck's own function is a ramp."""
    lines = ["MODE transient", "TIMEFUNCTION ramp 0.05", "TIMEFUNCTION pulse sine 3",
             "TIMEFUNCTION slow smoothstep 0.2", "X 1 0 0 0", "X 3 1 0 0",
             "BEAMS 1 1 2 3 4 4 0 1 0", "DYNE 1:4 1 2 3 4 5 6", "FIX 1", "FIX 2", "END",
             "HALT", "ESTIFF 1:4 1e4 1 1 1", "EM 1:4 1 2e-4 1e-4 1e-4 0",
             "ITERSTEP 30 1 1e-13"]
    if a:
        lines += [f"DELXF 3 0 {a} 0"] + (["LOADTF pulse DELXF 3"] if named else [])
    if b:
        lines += [f"DELQE 1:4 0 {b * (1 + i / 4)} 0 0 {b * (1 + (i + 1) / 4)} 0".replace(
            "1:4", str(i + 1)) for i in range(4)]
        lines += [f"LOADTF slow DELQE {i + 1}" for i in range(4)]
    lines += ["TIMESTEP 0.5 50", "END", "END"]
    return "\n".join(lines) + "\n"


def test_two_loads_with_their_own_functions_superpose(tmp_path):
    """In the linear range (deflections 3e-7 of the length) the response to both loads is
    the sum of the responses to each, to 1e-12 m (round-off of positions of order 1 m);
    one time function for both would miss by the size of the response."""
    both = run(tmp_path, _cantilever(1e-6, 2e-6), "ab")
    one = run(tmp_path, _cantilever(1e-6, 0.0), "a")
    two = run(tmp_path, _cantilever(0.0, 2e-6), "b")
    u = {k: r["position"] - r["position"][0] for k, r in (("ab", both), ("a", one),
                                                          ("b", two))}
    size = np.abs(u["ab"]).max()
    assert 1e-7 < size < 1e-6
    assert np.abs(u["ab"] - u["a"] - u["b"]).max() < 1e-12
    # the two histories differ: the loads do not just share one function
    tip = int(np.argmax(both["position"][0, :, 0]))
    ya, yb = u["a"][:, tip, 1], u["b"][:, tip, 1]
    assert abs(np.corrcoef(ya, yb)[0, 1]) < 0.9
    # the deck's function (ramp) for the tip force: another history altogether
    ramp = run(tmp_path, _cantilever(1e-6, 0.0, named=False), "ramp")
    assert np.abs(ramp["position"] - one["position"]).max() > 0.1 * size


def _same(a: dict, b: dict) -> None:
    for k in a:
        np.testing.assert_array_equal(a[k], b[k], err_msg=k)


def test_a_named_load_function_is_the_unnamed_one_bit_for_bit(tmp_path):
    """A DELXF following ``TIMEFUNCTION pulse sine 3`` (the deck's own: zero) gives exactly
    the states of the same DELXF under the deck's ``TIMEFUNCTION sine 3``."""
    named = _cantilever(1e-3, 0.0).replace("TIMEFUNCTION ramp 0.05", "TIMEFUNCTION zero")
    plain = _cantilever(1e-3, 0.0, named=False).replace("TIMEFUNCTION ramp 0.05",
                                                        "TIMEFUNCTION sine 3")
    _same(run(tmp_path, named, "named"), run(tmp_path, plain, "plain"))


def test_a_named_follower_load_function_is_the_unnamed_one_bit_for_bit(tmp_path):
    """A follower tip force (DELXFL, in the tip's axes) following ``TIMEFUNCTION pulse sine
    3`` with the deck's own function zero gives exactly the states of the same DELXFL under
    the deck's ``TIMEFUNCTION sine 3`` (LOADTF DELXFL was read, then ignored)."""
    def deck(text):
        return text.replace("DELXF 3 0 0.001 0", "DELXFL 3 4 0 0.001 0").replace(
            "LOADTF pulse DELXF 3", "LOADTF pulse DELXFL 3")
    named = deck(_cantilever(1e-3, 0.0)).replace("TIMEFUNCTION ramp 0.05", "TIMEFUNCTION zero")
    plain = deck(_cantilever(1e-3, 0.0, named=False)).replace("TIMEFUNCTION ramp 0.05",
                                                              "TIMEFUNCTION sine 3")
    assert "LOADTF pulse DELXFL 3" in named and "DELXFL" in plain
    a, b = run(tmp_path, named, "named"), run(tmp_path, plain, "plain")
    _same(a, b)
    assert np.abs(a["position"] - a["position"][0]).max() > 1e-6   # it did move
    job = job_from_text(named, "n.dat")
    assert [ld.tf for ld in job.model.follower_loads] == ["pulse"]


def _short(text: str, steps: str) -> str:
    return "\n".join(steps if line.startswith("TIMESTEP") else line
                     for line in text.splitlines()) + "\n"


@pytest.mark.parametrize("deck, old, new, steps", [
    ("spinup_beam.dat", "TIMEFUNCTION spinup 15",
     "TIMEFUNCTION zero\nTIMEFUNCTION hub spinup 15\nLOADTF hub DELINPR 2", "TIMESTEP 3 6"),
    ("slider_crank_flexible.dat", "TIMEFUNCTION spinup 0.05",
     "TIMEFUNCTION ramp 1\nTIMEFUNCTION crank spinup 0.05\nLOADTF crank DELINPX 2 1",
     "TIMESTEP 0.02 10"),
    ("two_link_arm_inverse.dat", "\nTIMEFUNCTION smoothstep 1.25",
     "\nTIMEFUNCTION zero\nTIMEFUNCTION s smoothstep 1.25\nLOADTF s DELINPE 10 1\n"
     "LOADTF s DELINPE 11 1", "TIMESTEP 1 8"),
])
def test_a_named_motion_function_is_the_unnamed_one_bit_for_bit(tmp_path, deck, old, new,
                                                                 steps):
    """Prescribed rotations (DELINPR), coordinates (DELINPX, here a planar angle) and
    deformations (DELINPE, in an inverse dynamics run) that name a function move exactly as
    under the deck's function of that kind."""
    text = _short((DECKS / deck).read_text(), steps)
    assert old in text
    _same(run(tmp_path, text.replace(old, new), "named"), run(tmp_path, text, "plain"))


def test_a_named_deformation_function_is_the_unnamed_one_bit_for_bit(tmp_path):
    """A prescribed deformation (DELINPE, the four-bar's crank hinge) and the force at C that
    name a function move exactly as under the deck's function of that kind (the deck's own
    function, zero, would hold the crank)."""
    text = _short((DECKS / "planar_four_bar_driven.dat").read_text(), "TIMESTEP 0.1 5")
    text = text.replace("INPUTE 11 1 0.0 6.0 0 ", "INPUTE 11 1 0.0\nDELINPE 11 1 6.0\n")
    plain = text.replace("MODE transient", "MODE transient\nTIMEFUNCTION linear")
    named = text.replace("MODE transient", "MODE transient\nTIMEFUNCTION zero\n"
                                           "TIMEFUNCTION crank linear\nLOADTF crank DELINPE 11 1\n"
                                           "LOADTF crank DELXF 5")
    a, b = run(tmp_path, named, "named"), run(tmp_path, plain, "plain")
    _same(a, b)
    # the crank turned by 6 t: 0.6 rad at t = 0.1 (B on a radius of 0.3 from A)
    assert np.isclose(np.arctan2(-a["position"][-1, 1, 0], a["position"][-1, 1, 1]), 0.6,
                      atol=1e-9)


# ---------------------------------------------------------------- the deck
_BASE = ("MODE transient\nX 1 0 0 0\nX 3 1 0 0\nBEAM 1 1 2 3 4 0 1 0\nDYNE 1 1 2 3 4 5 6\n"
         "FIX 1\nFIX 2\nEND\nHALT\nESTIFF 1 1 1 1 1\nEM 1 1\nDELXF 3 0 1 0\n"
         "DELQE 1 0 1 0\nTIMESTEP 1 10\n{lines}\nEND\nEND\n")


def test_named_functions_reach_the_model_and_settings():
    job = job_from_text(_BASE.format(lines="TIMEFUNCTION Pulse sine 2\nTIMEFUNCTION ramp 0.5\n"
                                       "LOADTF pulse DELXF 3\nLOADTF PULSE delqe 1"), "t.dat")
    assert job.settings.transient.time_function == ("ramp", (0.5,))
    assert job.settings.transient.named_time_functions == (("pulse", ("sine", (2.0,))),)
    assert [ld.tf for ld in job.model.loads] == ["pulse"]
    assert [ld.tf for ld in job.model.line_loads] == ["pulse"]


def deck_errors(lines: str) -> list[str]:
    with pytest.raises(DeckError) as exc:
        model_from_text(_BASE.format(lines=lines), "t.dat")
    return [line.split("t.dat:", 1)[1].replace(" error: ", " ")
            for line in str(exc.value).splitlines() if line.startswith("t.dat:")]


@pytest.mark.parametrize("lines, want", [
    ("LOADTF pulse DELXF 3", "15:8: LOADTF: no TIMEFUNCTION is named 'pulse' (named ones: "
                             "none; write TIMEFUNCTION pulse kind p...)"),
    ("TIMEFUNCTION pulse sine 2\nLOADTF pulse XF 3",
     "16:14: LOADTF: XF has no time function; expected one of DELXF, DELXFL, DELQE, DELQEL, "
     "DELINPX, DELINPE, DELINPR"),
    ("TIMEFUNCTION pulse sine 2\nLOADTF pulse DELXF 1",
     "16:20: LOADTF: no DELXF line on node 1"),
    ("TIMEFUNCTION pulse sine 2\nLOADTF pulse DELQE 2",
     "16:20: LOADTF: no DELQE line on element 2"),
    ("TIMEFUNCTION pulse sine 2\nLOADTF pulse DELINPX 3",
     "16:1: LOADTF: expected LOADTF pulse DELINPX n c"),
    ("TIMEFUNCTION pulse sine 2\nLOADTF pulse DELXF 3 1",
     "16:1: LOADTF: expected LOADTF pulse DELXF n"),
    ("TIMEFUNCTION pulse sine 2\nTIMEFUNCTION slow ramp 1\nLOADTF pulse DELXF 3\n"
     "LOADTF slow DELXF 3",
     "18:1: LOADTF: DELXF 3 is given a time function twice (lines 17 and 18)"),
    ("TIMEFUNCTION pulse sine 2\nTIMEFUNCTION pulse ramp 1",
     "16:14: TIMEFUNCTION pulse is given twice (lines 15 and 16)"),
    ("TIMEFUNCTION pulse wobble 2",
     "15:20: TIMEFUNCTION: unknown kind 'wobble'; expected constant"),
    ("TIMEFUNCTION pulse sine -2", "15:25: TIMEFUNCTION sine: the parameter must be "
                                   "positive, got -2"),
    ("TIMEFUNCTION sine 2\nTIMEFUNCTION ramp 1",
     "16:1: TIMEFUNCTION is given twice (lines 15 and 16)"),
])
def test_time_function_errors(lines, want):
    errors = deck_errors(lines)
    assert len(errors) == 1 and errors[0].startswith(want), errors


def test_the_deck_writer_keeps_line_loads_names_and_functions():
    """model_to_deck writes QE/DELQE, the named TIMEFUNCTIONs and the LOADTF lines: the
    deck it writes builds the same loads, motions and settings (planar and 3D)."""
    from dataclasses import replace

    from spacarpy.deck import model_to_deck

    def strip(items):
        return [replace(x, loc=None) for x in items]

    for text in (_cantilever(1e-6, 2e-6).replace("TIMESTEP", "QE 1 0 1e-6 0\nTIMESTEP"),
                 (DECKS / "slider_crank_flexible.dat").read_text().replace(
                     "TIMEFUNCTION spinup 0.05", "TIMEFUNCTION crank spinup 0.05\n"
                     "LOADTF crank DELINPX 2 1").replace("DELINPX 2 1 {w}",
                                                         "DELINPX 2 1 {w}\nDELQE 1 0 -1")):
        job = job_from_text(text, "a.dat")
        again = job_from_text(model_to_deck(job.model, job.settings), "b.dat")
        assert job.model.line_loads and strip(again.model.line_loads) == strip(
            job.model.line_loads)
        assert strip(again.model.loads) == strip(job.model.loads)
        assert strip(again.model.prescribed_rotations) == strip(
            job.model.prescribed_rotations)
        assert again.settings.transient == job.settings.transient


def test_a_drive_moving_at_t0_starts_the_mechanism_moving(tmp_path):
    """A DELINPE under TIMEFUNCTION linear turns the four-bar's crank at 6 rad/s from t = 0:
    the run starts with the velocities the constraints give (B and C at 6 x 0.3 m/s along
    -x, the crank being vertical and the coupler then translating), not at rest, so the work
    of the drive balances the kinetic energy (it drifted by 64 % of the energy in 0.1 s when
    the start was at rest, and the rotation-group update then stopped converging)."""
    text = _short((DECKS / "planar_four_bar_driven.dat").read_text(), "TIMESTEP 0.1 5")
    text = text.replace("INPUTE 11 1 0.0 6.0 0 ", "INPUTE 11 1 0.0\nDELINPE 11 1 6.0\n")
    deck = tmp_path / "lin.dat"
    deck.write_text(text.replace("MODE transient", "MODE transient\nTIMEFUNCTION linear"))
    out = tmp_path / "lin.h5"
    assert main(["run", str(deck), "-o", str(out), "-q"]) == 0
    with h5py.File(out, "r") as f:
        v0 = f["transient/velocity"][0]
        kin, work = f["transient/kinetic_energy"][()], f["transient/external_work"][()]
        elastic = f["transient/elastic_energy"][()]
    np.testing.assert_allclose(v0[1:3], [[-1.8, 0, 0], [-1.8, 0, 0]], atol=1e-12)
    balance = kin + elastic - work
    assert np.abs(balance - balance[0]).max() < 1e-3 * kin.max()     # (4e-5: h = 5 ms)
