"""The rolling contact's watch in the transient (issue 32, spec section 2.3): the lift-off
warning where a WHEEL's normal force turns negative, the per-step flags
/transient/elements/WHEEL/lift_off and friction_ratio, and the largest friction ratio in
the log (docs/rolling.md, "Transient")."""
from __future__ import annotations

import math

import h5py
import numpy as np
import pytest
from test_rolling_transient import _DISC, A, C, G, M, R  # noqa: F401

from spacarpy.cli import main
from spacarpy.elements.registry import KINDS

pytestmark = pytest.mark.skipif("WHEEL" not in KINDS, reason="needs the WHEEL kind")


def _run(tmp_path, name, data, steps=10, t_end=0.1, spin="DYNE 3 1"):
    deck = tmp_path / f"{name}.dat"
    deck.write_text(_DISC.format(alpha=0.1, spin=spin, data=data, steps=steps, t_end=t_end))
    out = tmp_path / f"{name}.h5"
    assert main(["run", str(deck), "-o", str(out)]) == 0
    with h5py.File(out) as f:
        tr = f["transient/elements/WHEEL"]
        return (tr["stress_resultant"][()], tr["lift_off"][()], tr["friction_ratio"][()],
                f.attrs.get("warnings", ""), f["transient/time"][()])


def test_friction_ratio_of_the_disc_rolling_down_a_slope(tmp_path, capsys):
    """C5's disc: the ground must give the friction C a/r^2 = 0.6529105448702562 N against a
    normal force m g cos(alpha) = 19.521981722754866 N at every step (the consistent
    multipliers), so the ratio is their quotient to 1e-9; nothing lifts off, no warning;
    the log names the largest ratio."""
    acc = G * math.sin(0.1) / (1 + C / (M * R * R))
    ratio = (C * acc / R ** 2) / (M * G * math.cos(0.1))
    assert ratio == pytest.approx(0.6529105448702562 / 19.521981722754866, rel=1e-14)
    sig, lift, fr, warnings, t = _run(
        tmp_path, "slope", "GRAVITY {9.81*sin(AL)} 0 {-9.81*cos(AL)}\nSTARTDE 3 1 10")
    log = capsys.readouterr().err
    assert lift.dtype == np.int8 and lift.shape == (11, 1) and not lift.any()
    np.testing.assert_allclose(fr[:, 0], ratio, rtol=1e-9)
    np.testing.assert_allclose(fr[:, 0], np.hypot(sig[:, 0, 3], sig[:, 0, 4]) / sig[:, 0, 5],
                               rtol=1e-15)
    assert warnings == ""
    assert "largest friction ratio |(nu4, nu5)|/nu6 needed by the rolling contact: 0.03344" \
        in log and "(WHEEL 5, time step" in log


def test_a_wheel_pulled_off_the_ground_is_warned_once_and_flagged_every_step(tmp_path,
                                                                             capsys):
    """Gravity turned upwards (z up): the ground must pull the disc down with m g = 19.62 N,
    a negative normal force from t = 0. One warning (log and the file's warnings) naming the
    wheel, the time step and the force; the flag set at every stored step."""
    sig, lift, fr, warnings, t = _run(tmp_path, "up", "GRAVITY 0 0 9.81\nSTARTDE 3 1 10")
    log = capsys.readouterr().err
    np.testing.assert_allclose(sig[:, 0, 5], -M * G, rtol=1e-9)
    assert lift.shape == (11, 1) and np.all(lift == 1)
    assert np.all(np.isinf(fr))
    want = ("time step 0 (t = 0 s): negative normal force (WHEEL mode 6) at WHEEL 5 (-19.62 "
            "N): the wheel would lift off the ground")
    assert warnings.count("\n") == 0 and warnings.startswith(want)
    assert log.count("negative normal force") == 1 and want in log


def test_a_lift_off_that_begins_during_the_run_is_warned_where_it_begins(tmp_path):
    """An upward force on the hub growing linearly in time (DELXF, phi(t) = t) exceeds the
    weight m g = 19.62 N at t = 19.62/40 = 0.4905 s: the stored steps flag the lift-off from
    t = 0.5 s on, and the one warning names time step 5 (t = 0.5 s)."""
    _, lift, _, warnings, t = _run(tmp_path, "lift", "GRAVITY 0 0 -9.81\nSTARTDE 3 1 10\n"
                                   "DELXF 3 0 0 40\nTIMEFUNCTION linear",
                                   steps=10, t_end=1.0)
    assert list(lift[:, 0]) == [0] * 5 + [1] * 6
    assert warnings.startswith("time step 5 (t = 0.5 s): negative normal force")


def test_a_wheel_carrying_no_load_is_not_flagged_by_round_off(tmp_path):
    """C7's disc without gravity (its spin prescribed): the normal force is zero up to the
    multipliers' round-off (about 1e-9 N, of either sign); no step is flagged or warned
    (before the round-off bound, 7 of 41 steps were)."""
    sig, lift, fr, warnings, t = _run(tmp_path, "spin", "INPUTE 3 1 0 {2*pi} 0", steps=40,
                                      t_end=1.0, spin="INPUTE 3 1")
    assert np.abs(sig[:, 0, 5]).max() < 1e-7
    assert not lift.any() and warnings == ""
