"""Shared fixtures of the test suite.

Plain helper functions live in helpers.py; no test module imports another test module.
Expensive shared inputs (real result files of the shipped decks) are session-scoped fixtures,
computed once per run.
"""
from __future__ import annotations

import os

# The command line sets one BLAS thread (spacarpy.cli.main) before numpy is imported; the
# in-process tests get the same setting, so they run the CLI's arithmetic. Set here, before
# any test module imports numpy; the user's own setting wins.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import shutil  # noqa: E402
from pathlib import Path  # noqa: E402

import pytest  # noqa: E402

from spacarpy.cli import main  # noqa: E402

from helpers import docs_sweep_args  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
DECKS = REPO / "decks"


# A clamped column of 4 elements with mass, loaded in compression below its Euler load
# (pi^2 EI / 4 L^2 = 2.47 N) in 4 steps: frequencies and buckling multipliers at every step.
COLUMN_DECK = """X 1 0 0 0
BEAMS 1  1 2 3 4  4  0 1 0
X 3 1 0 0
DYNE 1:4 1:6
FIX 1
FIX 2
END
HALT
ESTIFF 1:4 1e4 1 1 1
EM 1:4 1 0.01 0.005 0.005
DELXF 3 -2 0 0
ITERSTEP 20 4 1e-10
END
END
"""


WHEEL_DECK = """X 1 0 0 0.3
X 2 0 0 0
WHEEL 5 1 3 2 0 1 0
END
HALT
XM 1 2.0
XM 3 0.045 0 0 0.09 0 0.045
END
END
"""


def _wheel_file(out: Path) -> Path:
    """A file of a WHEEL model with one static and one transient step, written directly:
    no analysis runs a WHEEL yet (its slips), but the writer must hold its datasets."""
    import numpy as np

    from spacarpy.deck import model_from_text
    from spacarpy.results import ResultsWriter

    model = model_from_text(WHEEL_DECK, "wheel.dat")
    pos, eul = model.position_x0, np.array([[1.0, 0, 0, 0]])
    zero = {"WHEEL": np.zeros((1, 6))}
    with ResultsWriter(out, model, program_version="0.1.0", deformations="modified",
                       analysis="transient") as w:
        w.begin_static(2, 1, reaction_node=[], reaction_component=[], transient=True)
        w.static_step(0.0, pos, eul, zero, zero, reaction=np.zeros(0), iterations=1,
                      residual=0.0)
        w.transient_step(0.0, pos, eul, np.zeros((2, 3)), np.zeros((1, 4)), zero, zero,
                         kinetic_energy=0.0, elastic_energy=0.0, external_work=0.0,
                         iterations=1, residual=0.0, reaction=np.zeros(0))
        w.finish()
    return out


@pytest.fixture(scope="session")
def result_files(tmp_path_factory) -> dict:
    """Representative result files, {key: path}, written once per session.

    ``bend``: Table 2 (static, 8 elements); ``frame``: the portal frame with cross-sections
    (surface stresses); ``column``: eigen analysis with frequencies and buckling multipliers at
    every step and a compliance; ``arclength``: the two-bar truss followed by arc length (its
    critical points); ``failed``: a run that stopped with an error (partial file);
    ``kinematic``: KINE/KINX without slips, stopped after /model (partial file).
    """
    tmp = tmp_path_factory.mktemp("results")
    runs = {
        "bend": ("table2_bend_8el_modified", []),
        "frame": ("example_portal_frame", ["--set", "n=2"]),
        "column": ("column", ["--modes-per-step", "--modes", "3", "--compliance", "3", "4"]),
        "fourbar": ("four_bar_linkage", []),          # HINGE and RBEAM (schema 1.2)
        "truss": ("two_bar_truss", []),               # TRUSS (schema 1.2)
        "driven": ("driven", []),                     # a prescribed hinge angle (INPUTE)
        "planar": ("planar_four_bar", []),            # PLBEAM, PLHINGE (schema 1.3)
        "pltruss": ("pltruss", []),                   # PLTRUSS (schema 1.3)
        "transient": ("pendulum", []),                # /transient (schema 1.4)
        "state_space": ("state_space_cantilever", []),  # /state_space (schema 2.3)
        "arclength": ("two_bar_truss_arclength", []),  # /critical, arc_length (schema 2.4)
        "bicycle": ("benchmark_bicycle", []),   # mode 3 about a steady motion (schema 2.13)
        "inverse": ("two_link_arm_inverse", []),  # mode 2, accelerations (schema 2.15)
    }
    (tmp / "pendulum.dat").write_text((DECKS / "pendulum_rigid_90deg.dat").read_text()
                                      .replace("TIMESTEP 2.2 440", "TIMESTEP 0.1 10"))
    (tmp / "pltruss.dat").write_text(
        "X 1 -1 0\nX 3 0 0.3\nX 5 1 0\nPLTRUSS 1 1 3\nPLTRUSS 2 5 3\nDYNE 1:2 1\nFIX 1\n"
        "FIX 5\nEND\nHALT\nESTIFF 1:2 1e4\nDELXF 3 0 -50\nITERSTEP 20 4 1e-12\nEND\nEND\n")
    (tmp / "driven.dat").write_text(
        (DECKS / "hinged_rod_spring.dat").read_text()
        .replace("DYNE 10 1 ", "INPUTE 10 1").replace("ESTIFF 10 {k}", "DELINPE 10 1 0.5")
        .replace("DELXF 3 0 {F} 0", "").replace("EXPECT", "# EXPECT"))
    # short transient runs of the other element kinds (their /transient datasets)
    short = "MODE transient\n"
    (tmp / "truss_dyn.dat").write_text(short + (DECKS / "two_bar_truss.dat").read_text()
                                       .replace("ITERSTEP 20 4 1e-12", "EM 1:2 1\nTIMESTEP 0.01 2")
                                       .replace("EXPECT", "# EXPECT"))
    (tmp / "planar_dyn.dat").write_text(short + (DECKS / "planar_four_bar.dat").read_text()
                                        .replace("ITERSTEP 20 5 1e-12", "EM 1:3 1\nTIMESTEP 0.01 2")
                                        .replace("EXPECT", "# EXPECT"))
    (tmp / "pltruss_dyn.dat").write_text(
        short + (tmp / "pltruss.dat").read_text()
        .replace("ITERSTEP 20 4 1e-12", "EM 1:2 1\nTIMESTEP 0.01 2"))
    # PINBODY (schema 2.11): the hinged rod and the pendulum with the rod as a pin-body
    (tmp / "pinbody.dat").write_text(
        (DECKS / "hinged_rod_spring.dat").read_text()
        .replace("RBEAM 1 1 4 3 0 1 0", "PINBODY 1 1 4 3").replace("EXPECT", "# EXPECT"))
    (tmp / "pinbody_dyn.dat").write_text(
        (DECKS / "pendulum_rigid_90deg.dat").read_text()
        .replace("RBEAM 1 1 4 3 0 1 0", "PINBODY 1 1 4 3").replace("EM 1 {rhoA}", "XM 3 2.0")
        .replace("TIMESTEP 2.2 440", "TIMESTEP 0.01 2"))
    # DYNX (schema 2.16): a planar pendulum whose degree of freedom is a node's angle, mode 9
    (tmp / "dynx.dat").write_text(
        "MODE 9\nX 1 0 0\nX 3 1 0\nPLBEAM 1 1 2 3 4\nPLHINGE 2 5 2\nFIX 1\nFIX 5\n"
        "RLSE 2 1\nDYNX 2 1\nEND\nHALT\nESTIFF 2 3\nXM 3 2\nXF 3 0 -1\nEND\nEND\n")
    # BEAMW (schema 2.17): a twisted cantilever of two warping beams, static and transient
    beamw = ("X 1 0 0 0\nX 4 1 0 0\nX 7 2 0 0\nBEAMW 1 1 2 3 4 5 6 0 1 0\n"
             "BEAMW 2 4 5 6 7 8 9 0 1 0\nDYNE 1:2 1 2 3 4 5 6\nFIX 1\nFIX 2\nFIX 3\nEND\n"
             "HALT\nESTIFF 1:2 1e6 10 100 100 0 0 10\nEM 1:2 1 0.1 0.05 0.05 0 0.01\n"
             "DELXF 8 1 0 0\n")
    (tmp / "beamw.dat").write_text(beamw + "ITERSTEP 20 2 1e-12\nEND\nEND\n")
    (tmp / "beamw_dyn.dat").write_text("MODE transient\n" + beamw
                                       + "TIMESTEP 0.01 2\nEND\nEND\n")
    # BEAMC (schema 2.20): a quarter-circle cantilever of two curved beams, static, transient
    beamc = ("X 1 1 0 0\nX 3 0 1 0\nBEAMARC 1 1 2 3 4 2 0 0 0 0 0 -1 curved\n"
             "DYNE 1:2 1 2 3 4 5 6\nFIX 1\nFIX 2\nEND\nHALT\nESTIFF 1:2 1e6 10 100 100\n"
             "EM 1:2 1 0.1 0.05 0.05\nDELXF 3 0 0 1\n")
    (tmp / "beamc.dat").write_text(beamc + "ITERSTEP 20 2 1e-12\nEND\nEND\n")
    (tmp / "beamc_dyn.dat").write_text("MODE transient\n" + beamc
                                       + "TIMESTEP 0.01 2\nEND\nEND\n")
    # line and follower loads in /model (schema 2.23): the tilted ring with a QE and an XFL
    (tmp / "loads.dat").write_text(
        (DECKS / "ring_follower_pressure_3d.dat").read_text()
        .replace("ITERSTEP", "DELQE 2 0 0 1e-3 0 0 2e-3\nXFL 3 4 0 0 1e-3\nITERSTEP")
        .replace("EXPECT", "# EXPECT"))
    for key in ("truss_dyn", "planar_dyn", "pltruss_dyn", "pinbody", "pinbody_dyn", "dynx",
                "beamw", "beamw_dyn", "beamc", "beamc_dyn", "loads"):
        runs[key] = (key, [])
    (tmp / "column.dat").write_text(COLUMN_DECK)
    files = {}
    for key, (deck, extra) in runs.items():
        if (DECKS / f"{deck}.dat").exists():
            shutil.copy(DECKS / f"{deck}.dat", tmp / f"{deck}.dat")
        out = tmp / f"{key}.h5"
        assert main(["run", str(tmp / f"{deck}.dat"), "-o", str(out), "-q", *extra]) == 0
        files[key] = out
    files["wheel"] = _wheel_file(tmp / "wheel.h5")
    # kinematic coordinates without slips: stopped by the check after /model is written
    (tmp / "kinematic.dat").write_text(
        "X 1 0 0 0\nX 3 2 0 0\nRBEAM 1 1 4 3 0 1 0\nHINGE 10 2 4 0 0 1\nDYNE 10 1\n"
        "KINE 10 2\nKINX 3 3\nFIX 1\nFIX 2\nEND\nHALT\nESTIFF 10 3\nEND\nEND\n")
    assert main(["run", str(tmp / "kinematic.dat"), "-o", str(tmp / "kinematic.h5"),
                 "-q"]) == 3
    files["kinematic"] = tmp / "kinematic.partial.h5"
    shutil.copy(DECKS / "table1_cantilever_1el_basic.dat", tmp / "bad.dat")
    assert main(["run", str(tmp / "bad.dat"), "-o", str(tmp / "failed.h5"), "-q"]) == 1
    files["failed"] = tmp / "failed.partial.h5"
    return files




@pytest.fixture(scope="session")
def column_sweep(tmp_path_factory) -> Path:
    """docs/batch.md's sweep of a column over 21 load ratios (frequencies and buckling
    multipliers in one file), run as documented from the repository root."""
    out = tmp_path_factory.mktemp("sweep") / "column_sweep.h5"
    cwd = os.getcwd()
    os.chdir(REPO)
    try:
        assert main(docs_sweep_args(out)) == 0
    finally:
        os.chdir(cwd)
    return out
