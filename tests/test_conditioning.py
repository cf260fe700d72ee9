"""The conditioning limit before a run (spacarpy/solvers/statics/conditioning.py) and the message
instead of a traceback when memory runs out anyway: the 10^6-element cantilever of issue 20
stops before the solve. No 10^6 model is built here: the limit scales with the square of
the number of elements and is checked on small decks."""
from __future__ import annotations

import numpy as np
import pytest

from spacarpy.cli import main
from spacarpy.deck import model_from_text
from spacarpy.solvers.statics import conditioning

#: The Table 1 cantilever as the issue writes it: BEAMS ... {n}, 2 load steps.
DECK = """# Table 1 cantilever, n elements by BEAMS, 2 load steps
SET n {n}
DEFORMATIONS modified
MODE static
X 1 0 0 0
BEAMS 1  1 2 3 4  {{n}}  0 1 0
X 3 2 0 0
DYNE 1:{{n}} 1 2 3 4 5 6
FIX 1
FIX 2
END
HALT
ESTIFF 1:{{n}} 2070000000 1119392.307692308 1725000 1725000 0 0
DELXF 3 0 1293750 0
ITERSTEP 20 2 1e-09
END
END
"""
EPS = float(np.finfo(float).eps)


def test_kappa_is_the_closed_form_and_puts_the_limit_between_1e5_and_1e6_elements():
    model = model_from_text(DECK.format(n=10), "<cantilever 10>")
    kappa, size, l_min, r = conditioning.soft_direction_ratio(model)
    r2 = 1725000 / 2070000000                       # EI / EA (m^2)
    assert size == pytest.approx(2.0, rel=1e-15)
    assert l_min == pytest.approx(0.2, rel=1e-12)
    assert r == pytest.approx(np.sqrt(r2), rel=1e-15)
    assert kappa == pytest.approx((2 / 0.2) ** 2 * 4 / r2, rel=1e-12)
    # kappa grows with n^2 at a fixed model: 10^5 elements (measured to converge, eps kappa
    # = 1.1e-2) pass, 10^6 (measured to fail, eps kappa = 1.1) stop
    assert EPS * kappa * (1e5 / 10) ** 2 == pytest.approx(1.07e-2, rel=0.01)
    assert EPS * kappa * (1e5 / 10) ** 2 < conditioning.LIMIT
    assert EPS * kappa * (1e6 / 10) ** 2 > conditioning.LIMIT


def test_models_without_bending_beams_have_no_limit():
    text = """X 1 0 0 0
X 2 1 0 0
TRUSS 1 1 2
FIX 1
FIX 2 2 3
END
HALT
ESTIFF 1 1e6
DELXF 2 1 0 0
END
END
"""
    assert conditioning.soft_direction_ratio(model_from_text(text, "<truss>")) is None


def test_run_stops_before_the_solve_and_names_the_limit(tmp_path, capsys, monkeypatch):
    """With the limit lowered below the 1000-element deck's eps kappa (1.07e-6), as the
    10^6-element deck exceeds the real one: exit 2, the message, no result file, no
    traceback; --ignore-conditioning-limit runs it."""
    import spacarpy.memory as memory
    monkeypatch.setattr(memory, "available_bytes", lambda: 128 * 2**30)   # a large machine
    monkeypatch.setattr(conditioning, "LIMIT", 1e-6)
    deck = tmp_path / "cantilever.dat"
    deck.write_text(DECK.format(n=1000))
    assert main(["run", str(deck), "-q"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: the model's stiffness matrix is too ill-conditioned for "
                          "double precision")
    assert "about 2.1e-10 as stiff" in err and "shortest beam 0.002 m" in err
    assert "radius of gyration 0.0289 m" in err and "above the limit 1e-06" in err
    assert "--ignore-conditioning-limit" in err and "Traceback" not in err
    assert not deck.with_suffix(".h5").exists()
    assert main(["run", str(deck), "-q", "--ignore-conditioning-limit"]) == 0
    assert "running anyway" in capsys.readouterr().err
    assert deck.with_suffix(".h5").exists()


def test_out_of_memory_in_the_solve_is_a_message_not_a_traceback(tmp_path, capsys,
                                                                  monkeypatch):
    """Past every estimate (the SuperLU fallback's fill at 10^6 elements on 128 GB): exit
    1 (the analysis failed) with a message."""
    import spacarpy.run as run

    def out_of_memory(*args, **kwargs):
        raise MemoryError
    monkeypatch.setattr(run, "run_model", out_of_memory)
    deck = tmp_path / "cantilever.dat"
    deck.write_text(DECK.format(n=4))
    assert main(["run", str(deck), "-q"]) == 1
    err = capsys.readouterr().err
    assert err.startswith("error: out of memory") and "Traceback" not in err


# --- issue 34: the residual's round-off floor, for every element kind ------------------------

def _floor(text):
    from spacarpy.deck import job_from_text
    from spacarpy.solvers.statics.equilibrium import StaticProblem
    model, _ = job_from_text(text, "<deck>")
    return conditioning.residual_floor(StaticProblem(model))


def test_the_residual_floor_grows_with_the_cube_of_the_elements_and_knows_shear():
    """The shear-rigid Table 1 cantilever: the prospective floor is 3.55e-3 of the load at
    10^4 beams (the solver measured 2e-3 to 4e-3 at the solution), so 3.55e-6 at 10^3 and
    3.55e-9 at 10^2: the cube of the number of beams. The bench's GA = 10 EA has a third of
    it. An unloaded model has none."""
    rel_100, along = _floor(DECK.format(n=100))
    rel_1000, _ = _floor(DECK.format(n=1000))
    assert along == pytest.approx(100, rel=1e-9)
    assert rel_1000 == pytest.approx(3.55e-6, rel=0.02)
    assert rel_1000 / rel_100 == pytest.approx(1000, rel=0.02)
    shear = DECK.format(n=1000).replace("1725000 1725000 0 0", "1725000 1725000 8.333e-5 "
                                                               "8.333e-5")
    assert _floor(shear)[0] == pytest.approx(1.18e-6, rel=0.03)
    assert _floor(DECK.format(n=10).replace("DELXF 3 0 1293750 0", "")) is None


def test_a_floor_above_the_limit_stops_the_run_with_the_size_where_it_falls(
        tmp_path, capsys, monkeypatch):
    """With FLOOR_LIMIT lowered to 1e-6 (as the 10^5 shear-rigid deck's 3.6 exceeds the real
    2): the 1000-beam deck (3.55e-6) stops before the solve, exit 2, with the size where the
    limit falls: 1000 (1e-6 / 3.55e-6)^(1/3) = 656, given as 660."""
    monkeypatch.setattr(conditioning, "FLOOR_LIMIT", 1e-6)
    deck = tmp_path / "cantilever.dat"
    deck.write_text(DECK.format(n=1000))
    assert main(["run", str(deck), "-q"]) == 2
    err = capsys.readouterr().err
    assert "its round-off floor is 3.5" in err and "times the applied load" in err
    assert "the limit is at about 660 beams" in err and "Traceback" not in err
    assert main(["run", str(deck), "-q", "--ignore-conditioning-limit"]) == 0


def test_a_node_far_outside_the_model_is_named(tmp_path, capsys):
    """N11: X 5 1e20 0 0 used to give 'round-off leaves 2664...728.0 relative error ... at
    about 6.13e-15 elements; use longer elements'. The cause is named, the numbers sane."""
    import re
    from pathlib import Path
    text = (Path(__file__).resolve().parents[1] / "decks"
            / "table1_cantilever_8el_modified.dat").read_text()
    deck = tmp_path / "far.dat"
    deck.write_text(text.replace("X 9 1 0 0", "X 9 1e20 0 0"))
    assert main(["run", str(deck), "-q"]) == 2
    err = capsys.readouterr().err
    assert "node 9 lies 1e+20 m from the rest of the model" in err
    assert "check the X line" in err and "longer elements" not in err
    assert not re.search(r"\d{12}", err)
    assert conditioning.far_nodes(model_from_text(DECK.format(n=8), "<ok>")) is None


@pytest.mark.slow
def test_the_readme_shear_rigid_cantilever_at_10_5_is_refused_naming_the_limit(tmp_path,
                                                                               capsys):
    """README: the shear-rigid Table 1 cantilever reaches its round-off limit near 8 x 10^4
    elements and run refuses it beyond that before the solve. At 10^5 beams (report N4's
    deck) the floor is 3.55 times the load: exit 2, the limit 83,000 named, no result file
    (docs/performance.md, session 13)."""
    deck = tmp_path / "cantilever.dat"
    deck.write_text(DECK.format(n=100_000))
    out = tmp_path / "c.h5"
    assert main(["run", str(deck), "-q", "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "its round-off floor is 3.55 times the applied load (above the limit 2)" in err
    assert "the limit is at about 83,000 beams" in err and "Traceback" not in err
    assert not out.exists()
