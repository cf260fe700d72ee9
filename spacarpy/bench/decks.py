"""The cases of ``spacarpy bench``: their names, default sizes and titles, and the decks
of the cantilever, eigen, transient and arc-length cases (what each measures:
:mod:`spacarpy.bench.runner`)."""
from __future__ import annotations

CASES = ("cantilever", "bend", "eigen", "transient", "arclength", "spinup")
#: Cases timed as whole processes only, on shipped decks: the ``spacarpy`` command (after the
#: word ``spacarpy``) with the deck in the place of ``{deck}``.
DECK_CASES = {
    "pendulum": ("run", "{deck}/pendulum_rigid_90deg.dat"),
    "sweep": ("sweep", "{deck}/leafspring_guidance_sweep.dat", "--set", "phi=0:0.002:21",
              "-j", "2"),
}
#: shear stiffness GA / EA of the benchmark cantilever (Exudyn's SHEAR_FACTOR)
SHEAR = 10.0
DEFAULT_SIZES = {"cantilever": (10, 100, 1000, 10000), "bend": (10, 100, 1000, 10000),
                 "eigen": (10, 100, 1000, 10000), "transient": (10, 100),
                 "arclength": (1000, 10000), "spinup": (10,)}
TITLES = {
    "cantilever": "Static cantilever (Table 1 load, GA = 10 EA, 10 load steps, Newton to 1e-8)",
    "bend": "Static 45-degree bend (Table 2 load, 10 load steps, Newton to 1e-8)",
    "eigen": "10 lowest eigenfrequencies of the unloaded steel cantilever",
    "transient": "Transient cantilever (load raised in 20 ms, {steps} steps of 1 ms, "
                 "rho_inf = 0.5)",
    "arclength": "Clamped column past buckling by arc length (1.5 P_E, imperfection 1e-2, "
                 "EA = 1e4 EI, Newton to 1e-6)",
    "spinup": "Spin-up of a flexible beam (Simo & Vu-Quoc; to 4 rad/s in 15 s, h = 0.05 s, "
              "rho_inf = 0.5, t_end = {t_end:g} s)",
    "pendulum": "Rigid pendulum released from 90 degrees, 440 transient steps (whole process)",
    "sweep": "Leaf-spring guidance sweep, 21 points on 2 jobs (whole process)",
}
#: ARCLENGTH line of the bench column: n_max ds0 ds_min ds_max
ARCLENGTH_LINE = "ARCLENGTH 400 0.02 0.0001 0.02"
#: Axial stiffness of the bench column (slenderness 100): the residual's round-off floor grows
#: with the stiffest element's EA/l, and with the unit beam's EA = 1e6 it is 5e-6 at 10^4
#: elements, above any tolerance that tells quadratic convergence apart
ARCLENGTH_EA = 1e4
#: Lateral tip force of the bench column, relative to the axial one
ARCLENGTH_IMPERFECTION = 1e-2


def _steel_mass_line(n: int) -> str:
    from spacarpy.bench.cases import CANTILEVER
    rho, a = 7850.0, CANTILEVER["a"]
    return (f"EM 1:{n} {rho * a * a!r} {rho * a**4 / 6!r} {rho * a**4 / 12!r} "
            f"{rho * a**4 / 12!r} 0")


def eigen_cantilever_deck(n: int) -> str:
    """The bench cantilever with steel mass, MODE eigen, no load."""
    from spacarpy.bench.cases import cantilever_deck
    text = cantilever_deck(n, n_steps=1, tol=1e-8, compact=True, shear=SHEAR)
    lines = [ln for ln in text.splitlines()
             if not ln.startswith(("EXPECT", "DELXF")) and "Table 1 of the paper" not in ln]
    text = "\n".join(lines).replace("MODE static", "MODE eigen")
    return text.replace("ITERSTEP 20 1 1e-08", f"{_steel_mass_line(n)}\nITERSTEP 20 1 1e-08")


def transient_cantilever_deck(n: int, n_steps: int, dt: float = 1e-3) -> str:
    """The bench cantilever as a transient deck: at rest, the tip force from t = 0 on."""
    from spacarpy.bench.cases import cantilever_deck
    text = cantilever_deck(n, n_steps=1, tol=1e-8, compact=True, shear=SHEAR)
    lines = [ln for ln in text.splitlines() if not ln.startswith("EXPECT")]
    text = "\n".join(lines).replace("MODE static", "MODE transient\nRHOINF 0.5")
    # a tenth of Table 1's force, raised smoothly over 20 ms (a sudden load would send a
    # stress wave through the fine meshes that 1 ms steps cannot follow): a deflection of a
    # few cm, vibrating at the first frequency (about 21 Hz, 48 steps of 1 ms per period)
    text = text.replace(" 1293750 0", " 129375 0").replace(
        "RHOINF 0.5", "RHOINF 0.5\nTIMEFUNCTION smoothstep 0.02")
    return text.replace("ITERSTEP 20 1 1e-08", f"{_steel_mass_line(n)}\nITERSTEP 20 1 1e-08\n"
                        f"TIMESTEP {n_steps * dt!r} {n_steps}")



def arclength_deck(n: int) -> str:
    """The bench column of the arc-length case (see the module docstring)."""
    from spacarpy.bench.cases import arclength_column_deck
    return arclength_column_deck(n, ds0=0.02, tol=1e-6, ea=ARCLENGTH_EA,
                                 imperfection=ARCLENGTH_IMPERFECTION).replace(
        "ARCLENGTH 200 0.02", ARCLENGTH_LINE)


