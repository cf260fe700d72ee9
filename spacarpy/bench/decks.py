"""The cases of ``spacarpy bench``: their names, default sizes and titles, and the decks
of the cantilever, eigen, transient, arc-length and lattice cases (what each measures:
:mod:`spacarpy.bench.runner`)."""
from __future__ import annotations

CASES = ("cantilever", "bend", "eigen", "transient", "arclength", "spinup", "lattice")
#: Cases timed as whole processes only, on shipped decks: the ``spacarpy`` command (after the
#: word ``spacarpy``) with the deck in the place of ``{deck}``.
DECK_CASES = {
    "pendulum": ("run", "{deck}/pendulum_rigid_90deg.dat"),
    "sweep": ("sweep", "{deck}/leafspring_guidance_sweep.dat", "--set", "phi=0:0.002:21",
              "-j", "2"),
}
#: ``--peer`` choices and the cases each solves (Exudyn has no arc length; OpenSees the
#: lattice alone: spacarpy.bench.peers)
PEERS = {"exudyn": tuple(c for c in CASES if c != "arclength"), "opensees": ("lattice",)}
#: shear stiffness GA / EA of the benchmark cantilever (Exudyn's SHEAR_FACTOR)
SHEAR = 10.0
DEFAULT_SIZES = {"cantilever": (10, 100, 1000, 10000), "bend": (10, 100, 1000, 10000),
                 "eigen": (10, 100, 1000, 10000), "transient": (10, 100),
                 "arclength": (1000, 10000), "spinup": (10,),
                 # target numbers of beams (lattice_grid); 3x10^4 and 10^5 with --case-sizes
                 "lattice": (1000, 10000)}
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
    "lattice": "3D beam lattice (k x k x m grid, beams 0.1 m, square 0.01 m, steel, bottom "
               "clamped, 50 N along x on every top node, 2 load steps, Newton to 1e-8)",
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




# ----------------------------------------------------------------------------------------
# the 3D beam lattice (docs/performance.md, "A well-conditioned model: the 3D beam lattice")
# ----------------------------------------------------------------------------------------
#: the lattice: members of ``l`` m, square section ``a`` m, steel, shear factor 5/6, a force
#: ``F`` N along +x on every top node, ``steps`` load steps, Newton to ``tol``
LATTICE = dict(l=0.1, a=0.01, E=207e9, nu=0.3, kappa=5 / 6, F=50.0, steps=2, tol=1e-8)


def lattice_elements(kx: int, ky: int, m: int) -> int:
    """Beams of the ``kx x ky x m`` lattice: columns between the m layers, and beams along x
    and y in every layer (the clamped bottom one too)."""
    return kx * ky * (m - 1) + (ky * (kx - 1) + kx * (ky - 1)) * m


def lattice_grid(elements: int) -> tuple[int, int, int]:
    """The square lattice ``(k, k, m)`` about twice as tall as wide (``k`` from
    ``6 k^3 = elements``) whose number of beams is nearest to ``elements``."""
    k = max(2, round((elements / 6) ** (1 / 3)))
    m = max(2, round((elements + k * k) / (3 * k * k - 2 * k)))
    return k, k, min((mm for mm in (m - 1, m, m + 1) if mm >= 2),
                     key=lambda mm: abs(lattice_elements(k, k, mm) - elements))


def lattice_stiffness() -> tuple[float, ...]:
    """ESTIFF of a lattice member: EA GJ EIy EIz and the shear flexibilities EI / kGA."""
    c = LATTICE
    area, inertia = c["a"] ** 2, c["a"] ** 4 / 12
    g = c["E"] / (2 * (1 + c["nu"]))
    flex = c["E"] * inertia / (c["kappa"] * g * area)       # EI / kGA
    return (c["E"] * area, g * 0.1406 * c["a"] ** 4, c["E"] * inertia, c["E"] * inertia,
            flex, flex)


def lattice_node(kx: int, ky: int, i: int, j: int, level: int) -> int:
    """Position node of grid point (i, j, level), i < kx along x, j < ky along y, level < m
    along z (its orientation node is the next number)."""
    return 2 * ((level * ky + j) * kx + i) + 1


def lattice_deck(kx: int, ky: int, m: int) -> str:
    """The lattice as deck text: ``kx x ky x m`` grid points ``l`` apart, a BEAM between
    neighbours along x, y and z, the bottom layer clamped, ``F`` along +x on every top node,
    ``steps`` load steps (``decks/lattice.dat`` is this text at 5 x 5 x 8)."""
    from spacarpy.bench.cases import _fmt
    c = LATTICE
    l = c["l"]                                              # noqa: E741
    node = lambda i, j, lev: lattice_node(kx, ky, i, j, lev)  # noqa: E731
    n_el = lattice_elements(kx, ky, m)
    lines = [f"# 3D beam lattice, {kx} x {ky} x {m} grid points, {n_el} beams",
             f"# members {c['l']:g} m, square {c['a']:g} m, E = {c['E']:g} Pa, nu = "
             f"{c['nu']:g}, shear factor 5/6; bottom layer clamped,",
             f"# {c['F']:g} N along +x on every top node, {c['steps']} load steps",
             "# generated by spacarpy.bench.decks.lattice_deck(kx, ky, m) "
             "(spacarpy bench --cases lattice)",
             "# node 2g+1 = position, 2g+2 = orientation of grid point g = "
             "(level*ky + j)*kx + i",
             "# the grid is written out: spacarpy bench --cases lattice scales it", "",
             "DEFORMATIONS modified", "MODE static", "",
             *(f"{text:<30}# {note}" for text, note in (
                 (f"SET E {c['E']:g}", "Young's modulus (Pa)"),
                 (f"SET G {{E/{2 * (1 + c['nu']):g}}}", f"shear modulus (Pa), nu = {c['nu']:g}"),
                 (f"SET a {c['a']:g}", "square section (m)"),
                 (f"SET F {c['F']:g}", "force along +x on each top node (N)"))),
             ""]
    for lev in range(m):
        for j in range(ky):
            for i in range(kx):
                lines.append(f"X {node(i, j, lev)} {_fmt(i * l)} {_fmt(j * l)} "
                             f"{_fmt(lev * l)}")
    e = 0
    for lev in range(m):
        for j in range(ky):
            for i in range(kx):
                p = node(i, j, lev)
                ends = []
                if i + 1 < kx:
                    ends.append((node(i + 1, j, lev), "0 0 1"))
                if j + 1 < ky:
                    ends.append((node(i, j + 1, lev), "0 0 1"))
                if lev + 1 < m:
                    ends.append((node(i, j, lev + 1), "1 0 0"))
                for q, o in ends:
                    e += 1
                    lines.append(f"BEAM {e} {p} {p + 1} {q} {q + 1} {o}")
    lines.append(f"DYNE 1:{n_el} 1:6")
    for j in range(ky):
        for i in range(kx):
            p = node(i, j, 0)
            lines += [f"FIX {p}", f"FIX {p + 1}"]
    lines += ["END", "HALT", ""]
    # lattice_stiffness() in expressions of the SET parameters (shear factor 5/6)
    lines.append(f"ESTIFF 1:{n_el} {{E*a^2}} {{G*0.1406*a^4}} {{E*a^4/12}} {{E*a^4/12}} "
                 "{E*a^2/12/(5/6*G)} {E*a^2/12/(5/6*G)}")
    for j in range(ky):
        for i in range(kx):
            lines.append(f"DELXF {node(i, j, m - 1)} {{F}} 0 0")
    lines.append(f"ITERSTEP 20 {c['steps']} {c['tol']:g}")
    lines += ["END", "END", ""]
    return "\n".join(lines)
