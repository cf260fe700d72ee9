"""The energy balance of driven transients (issue 34, item 9): the work W of every prescribed
coordinate (INPUTX, INPUTR) and deformation (INPUTE, DELINPE) has the sign of the work done
ON the model, so that ``T + U + D - W`` stays constant to the integrator's error.

- a hinge driven at a constant rate (or along TIMEFUNCTION spinup) winds a torsion spring
  with no moving mass: ``W = U`` at every step to the Newton tolerance (the trapezoidal
  rule integrates the spring's linear torque exactly);
- the same drive with a rod on the spring's far side: ``T + U - W`` constant to O(h^2),
  shown by halving h twice (the measured ratios are 4.1 and 4.0);
- the driven wheel (decks/driven_wheel.dat): the drive's work is the kinetic energy gained;
- every shipped driven deck (the wheel and the four-bar: INPUTE; slider-crank: INPUTX;
  spin-up, Southwell: INPUTR) on shortened runs (slow): O(h^2) over two halvings of h,
  and at the deck's own h the value of docs/transient.md's table.
"""
from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import numpy as np
import pytest

from spacarpy.deck import job_from_text
from spacarpy.solvers.dynamics.transient import TransientOptions, solve_transient

from helpers import slider_deck

DECKS = Path(__file__).resolve().parents[1] / "decks"

# a rigid rod on orientation node 6 (Izz = 0.5 kg m^2) hangs on a torsion spring k = 3 N m/rad
# (hinge 11) from orientation node 4, which hinge 10 turns about z with the prescribed drive
WIND = """X 1 0 0 0
X 3 1 0 0
RBEAM 1 1 6 3 0 1 0
HINGE 10 2 4 0 0 1
HINGE 11 4 6 0 0 1
DYNE 11 1
FIX 1
FIX 2
{fix}
INPUTE 10 1
END
HALT
ESTIFF 11 3.0
XM 6 0.3 0 0 0.3 0 0.5
{drive}
TIMESTEP {t_end} {n}
RHOINF 1
MODE transient
END
END
"""
HELD = "FIX 6\nRLSE 11 2 3"          # the rod held: the drive only winds the spring


def energies(text: str, **changes):
    """(t, T, U, W, D) per stored step of the transient of a deck text."""
    job = job_from_text(text)
    opts = dataclasses.replace(TransientOptions.from_settings(job.settings), **changes)
    steps = solve_transient(job.model, opts).steps
    return tuple(np.array([getattr(s, f) for s in steps]) for f in (
        "time", "kinetic_energy", "elastic_energy", "external_work", "dissipated_energy"))


def balance_error(text: str, **changes) -> float:
    """max |E - E0| / max(T + U), E = T + U + D - W."""
    _, T, U, W, D = energies(text, **changes)
    e = T + U + D - W
    return float(np.abs(e - e[0]).max() / (T + U).max())


@pytest.mark.parametrize("drive", [
    "INPUTE 10 1 0.0 2.0 0",                          # 5 fields: 2 rad/s from the start
    "DELINPE 10 1 2.0\nTIMEFUNCTION spinup 0.5"])     # 2 phi(t), rising in 0.5 s
def test_a_driven_hinge_winding_a_spring_does_work_w_equal_u(drive):
    """Without a moving mass the drive's work is the spring's energy, ``W = U = k theta^2/2``
    at every step (to the Newton tolerance: measured 2e-11 J of 6 J); the former sign gave
    ``W = -U``."""
    t, T, U, W, _ = energies(WIND.format(fix=HELD, drive=drive, t_end=1.0, n=20))
    assert np.all(T == 0.0)
    assert U[-1] > 3.0                            # wound: 6 J (rate), 3.375 J (spinup)
    np.testing.assert_allclose(W, U, rtol=0, atol=1e-10 * U.max())
    if drive.startswith("INPUTE"):                # theta = 2 t: U = k theta^2 / 2
        np.testing.assert_allclose(U, 1.5 * (2.0 * t) ** 2, rtol=1e-12, atol=1e-14)


def test_a_driven_hinge_winding_a_spring_with_a_rod_conserves_energy_to_second_order():
    """The rod swings on the wound spring: ``T + U - W`` stays constant (RHOINF 1, 2 s = 1.6
    periods of the rod, 50, 100 and 200 steps). The rod turns about the fixed hinge axis,
    where the update of the Euler parameters on the rotation group is the trapezoidal rule
    on the angle, which conserves the energy of this linear spring exactly: measured
    1.2e-12 to 1.6e-12 of max(T + U) = 4 J. (The linear update of the Euler parameters
    before issue 32: 1.4e-3, 3.4e-4, 8.4e-5, second order.)"""
    errors = [balance_error(WIND.format(fix="", drive="INPUTE 10 1 0.0 2.0 0", t_end=2.0,
                                        n=n)) for n in (50, 100, 200)]
    assert max(errors) < 1e-10


def shortened(name: str, t_end: float, n: int, substeps: int, extra: str = "") -> str:
    """A shipped deck with its TIMESTEP and SUBSTEPS replaced (and ``extra`` lines added)."""
    src = (DECKS / f"{name}.dat").read_text()
    src = re.sub(r"^TIMESTEP .*$", f"TIMESTEP {t_end} {n}\nSUBSTEPS {substeps}\n{extra}",
                 src, flags=re.M)
    lines = src.splitlines()
    first = next(i for i, s in enumerate(lines) if s.startswith("SUBSTEPS"))
    return "\n".join(s for i, s in enumerate(lines) if i <= first
                     or not s.startswith("SUBSTEPS")) + "\n"


def test_the_driven_wheel_receives_the_kinetic_energy_it_gains():
    """decks/driven_wheel.dat (Izz = 0.5 kg m^2, ``INPUTE 2 1 0 20 10``): the hinge holds
    sigma = -I alpha, and the drive's work is the kinetic energy the wheel gains,
    ``I ((w + alpha t)^2 - w^2) / 2`` (56.25 J at 0.5 s); the former sign gave -56 J. A
    constant angular acceleration about a fixed axis is integrated exactly by the update of
    the Euler parameters on the rotation group (issue 32): measured 2.5e-9, 1.7e-11 J at
    h = 5, 2.5 ms (RHOINF 0's start-up of the multipliers; with the linear update before
    it, 0.98 and 0.24 J, second order)."""
    errors = []
    for substeps in (1, 2):
        t, T, _, W, _ = energies(shortened("driven_wheel", 0.5, 100, substeps))
        gained = 0.25 * ((20.0 + 10.0 * t) ** 2 - 400.0)
        assert gained[-1] == pytest.approx(56.25)
        errors.append(np.abs(W - gained).max())
        np.testing.assert_allclose(T - T[0], gained, rtol=0, atol=1.5 * errors[-1])
    assert max(errors) < 1e-8 * gained[-1]


#: The shipped driven decks (issue 34): (deck, its drive, shortened run (s), stored steps of
#: it, SUBSTEPS of the three runs (h, h/2, h/4), the error measured at the deck's own h).
#: The error of ``T + U + D - W`` relative to max(T + U), docs/transient.md's table. None:
#: exact (the driven wheel's constant angular acceleration about its axle, exact for the
#: update of the Euler parameters on the rotation group, issue 32; 9.0e-4 before).
DRIVEN = [
    ("driven_wheel", "INPUTE", 0.5, 100, (1, 2, 4), None),
    ("planar_four_bar_driven", "INPUTE", 1.0, 100, (2, 4, 8), 4.7e-4),
    ("slider_crank_flexible", "INPUTX", 0.05, 50, (1, 2, 4), 1.67e-3),
    ("spinup_beam", "INPUTR", 6.0, 60, (1, 2, 4), 6.45e-5),
    ("rotating_cantilever_southwell", "INPUTR", 3.0, 30, (5, 10, 20), 2.75e-5),
]


def own_substeps(name: str, t_end: float, n: int) -> int:
    """The SUBSTEPS that give a shortened run of ``n`` stored steps over ``t_end`` the time
    step of the shipped deck."""
    text = (DECKS / f"{name}.dat").read_text()
    t_deck, n_deck = re.search(r"^TIMESTEP (\S+) (\S+)", text, flags=re.M).groups()
    substeps = int(re.search(r"^SUBSTEPS (\d+)", text, flags=re.M)[1])
    return round(t_end / n / (float(t_deck) / int(n_deck) / substeps))


@pytest.mark.slow
@pytest.mark.parametrize("name, drive, t_end, n, subs, measured", DRIVEN,
                         ids=[d[0] for d in DRIVEN])
def test_every_shipped_driven_deck_conserves_energy_to_second_order(name, drive, t_end, n,
                                                                    subs, measured):
    """Each shipped deck driven by a prescribed motion, on a shortened run at three time
    steps h, h/2, h/4 about its own h0: ``T + U + D - W`` is constant to O(h^2), the error
    falling by more than 3 per halving (4 in the limit; measured 3.3 to 4.1,
    docs/transient.md), and at h0 it is below what second order predicts from the next
    finer run with 12 % to spare (``4.5 e(h0/2)``: h0 lies in the asymptotic range) and
    within 20 % of the value measured when the turning frame's switch-on became
    independent of h (``measured``; a lost term of the work, or a frame switched on by the
    step size again, moves it by far more)."""
    assert re.search(rf"^{drive} ", (DECKS / f"{name}.dat").read_text(), flags=re.M)
    own = own_substeps(name, t_end, n)
    assert own in subs[:2]
    errors = [balance_error(shortened(name, t_end, n, s)) for s in subs]
    if measured is None:                          # exact: round-off (measured 1e-13..2e-11)
        assert max(errors) < 1e-9, errors
        return
    assert errors[0] / errors[1] > 3.0 and errors[1] / errors[2] > 3.0, errors
    k = subs.index(own)
    assert errors[k] < 4.5 * errors[k + 1]
    assert errors[k] == pytest.approx(measured, rel=0.2)




def test_transient_reactions_hold_the_prescribed_motion(tmp_path):
    """``/transient/reaction`` (schema 2.8): the force that drives the slider's x is
    ``m a0 = -1.6 N`` at every step, the fixed y carries its weight ``m g``, in the order
    and with the names of ``/static/reaction_node`` (the truss, its elongation released,
    carries nothing to node 1)."""
    from spacarpy.cli import main
    from spacarpy.results import open_results
    from spacarpy.results.tables import extract

    deck, out = tmp_path / "slider.dat", tmp_path / "slider.h5"
    deck.write_text(slider_deck(0.5, -0.8, steps=10, gravity=True))
    assert main(["run", str(deck), "-o", str(out), "-q"]) == 0
    with open_results(out) as res:
        tr = res.transient
        assert tr.n_step == 11
        at_slider = tr.reaction(node=3)
        assert tr.reaction().shape == (11, len(tr.reaction_component))
        np.testing.assert_allclose(at_slider[:, 0], 2.0 * -0.8, rtol=1e-9)
        np.testing.assert_allclose(at_slider[:, 1], 2.0 * 9.81, rtol=1e-9)
        np.testing.assert_allclose(at_slider[:, 2], 0.0, atol=1e-9)
        np.testing.assert_allclose(tr.reaction(node=1), 0.0, atol=1e-9)
        # spacarpy extract reaction: the time history of a file without load steps
        table = extract(res, "reaction", node=3, step=-1)
        assert table.names[:2] == ["time", "step"]
        values = dict(zip(table.columns[3].tolist(), table.columns[4].tolist()))
        assert values["Fx"] == pytest.approx(-1.6, rel=1e-9)
        assert values["Fy"] == pytest.approx(2.0 * 9.81, rel=1e-9)
