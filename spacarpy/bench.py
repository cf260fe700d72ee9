"""``spacarpy bench``: time the solvers on cantilevers and a bend of growing size.

Cases (all in :mod:`spacarpy.cases` terms, modified deformations):

``cantilever``
    Table 1 cantilever (tip force 3EI/L^2, a large deflection), ``n`` elements, 10 load steps,
    Newton to 1e-8, with the shear stiffness GA = 10 EA of the Exudyn comparison (Exudyn's
    beam cannot be shear rigid; with the same physics both codes must reach the same tip).
    The eigen and transient cases use the same beam.
``bend``
    Table 2 45-degree bend, ``n`` elements, 10 load steps.
``eigen``
    The cantilever of steel (rho = 7850 kg/m^3, rotary inertia included), unloaded: its 10
    lowest eigenfrequencies (linearization and the sparse shift-invert eigensolver).
``transient``
    The same cantilever at rest, a tenth of the Table 1 force raised smoothly in 20 ms,
    1000 generalized-alpha steps of 1 ms (rho_inf = 0.5).
``arclength``
    The clamped unit column past buckling by arc-length continuation
    (:func:`spacarpy.cases.arclength_column_deck`: 1.5 times the Euler load with a lateral
    imperfection of 1e-2, EA = 1e4 EI, ``ARCLENGTH 400 0.02 1e-4 0.02``, Newton to 1e-6):
    the points, the Newton iterations per point, and the order of convergence measured on
    the residual history (above 10 times its round-off floor, which grows with the stiffest
    element's stiffness) and on the increments of one post-buckling point (an arc length of
    0.1 from the point at load factor 0.7; 2 is quadratic).
``spinup``
    Simo & Vu-Quoc's spin-up (:mod:`spacarpy.spinup`: ``decks/spinup_beam.dat`` with ``n``
    elements, h = 0.05 s, rho_inf = 0.5, final rate 4 rad/s, to ``spinup_t_end`` = 30 s, every
    step stored): wall time of the whole run (solve and results file), time steps, Newton
    iterations per step (mean over all steps and over t > 16 s at constant speed), and the
    tip's peak lag in the rotating frame; with ``--peer exudyn`` Exudyn's 2D geometrically
    exact beam on the same problem (:mod:`spacarpy.peers.exudyn_spinup`).
``pendulum``, ``sweep``
    Whole processes on shipped decks (:data:`DECK_CASES`): ``spacarpy run
    decks/pendulum_rigid_90deg.dat`` (a rigid pendulum, 440 transient steps) and ``spacarpy
    sweep decks/leafspring_guidance_sweep.dat --set phi=0:0.002:21 -j 2`` (21 points).

Every (case, size) runs in a fresh process, so that its peak memory (the process's maximum
resident set) is its own; inside it the solve is repeated and the minimum and median are
shown. Set-up (deck parsing, numbering, sparsity pattern) is timed apart from the solve. The
static tables split the time per Newton iteration into element kernels, assembly, sparse
factorizations and solves, and the rest (norms, bookkeeping). With ``--peer exudyn`` the same
problems are solved by Exudyn (:mod:`spacarpy.peers.exudyn_cantilever`) in the same run, and the
ratio of the solve times (spacarpy / Exudyn) is shown with the result each code reaches. The
cantilever rows up to :data:`WHOLE_PROCESS_MAX` elements also time the whole process
(:func:`whole_process`): ``spacarpy run`` as a subprocess against the Exudyn script as a
subprocess, best of ``repeat``.
``--markdown FILE`` writes the tables as docs/performance.md is made. Nothing else is written;
numbers are never asserted in tests.

The module is longer than 600 lines because the notes printed with every table (what each
case measures, and the small-model measurements) live here, beside the cases they describe,
so that ``--markdown`` regenerates docs/performance.md whole.
"""
from __future__ import annotations

import datetime
import multiprocessing
import platform
import resource
import statistics
import sys
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from spacarpy.deck import job_from_text

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


# ----------------------------------------------------------------------------------------
# decks
# ----------------------------------------------------------------------------------------
def _steel_mass_line(n: int) -> str:
    from spacarpy.cases import CANTILEVER
    rho, a = 7850.0, CANTILEVER["a"]
    return (f"EM 1:{n} {rho * a * a!r} {rho * a**4 / 6!r} {rho * a**4 / 12!r} "
            f"{rho * a**4 / 12!r} 0")


def eigen_cantilever_deck(n: int) -> str:
    """The bench cantilever with steel mass, MODE eigen, no load."""
    from spacarpy.cases import cantilever_deck
    text = cantilever_deck(n, n_steps=1, tol=1e-8, compact=True, shear=SHEAR)
    lines = [ln for ln in text.splitlines()
             if not ln.startswith(("EXPECT", "DELXF")) and "Table 1 of the paper" not in ln]
    text = "\n".join(lines).replace("MODE static", "MODE eigen")
    return text.replace("ITERSTEP 20 1 1e-08", f"{_steel_mass_line(n)}\nITERSTEP 20 1 1e-08")


def transient_cantilever_deck(n: int, n_steps: int, dt: float = 1e-3) -> str:
    """The bench cantilever as a transient deck: at rest, the tip force from t = 0 on."""
    from spacarpy.cases import cantilever_deck
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


# ----------------------------------------------------------------------------------------
# one (case, size), run inside a child process
# ----------------------------------------------------------------------------------------
def _peak_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def _static_row(case: str, n: int, repeat: int, n_steps: int) -> dict:
    from spacarpy.cases import bend_deck, cantilever_deck
    from spacarpy.solvers.statics.static import StaticOptions, StaticProblem, solve_static
    text = (cantilever_deck(n, n_steps=n_steps, tol=1e-8, compact=True, shear=SHEAR)
            if case == "cantilever"
            else bend_deck(n, n_steps=n_steps, tol=1e-8))
    t0 = time.perf_counter()
    model, settings = job_from_text(text, f"<{case} {n}>")
    parse = time.perf_counter() - t0
    totals, timings, setups = [], [], []
    for _ in range(max(repeat, 1)):
        t1 = time.perf_counter()
        prob = StaticProblem(model, deformations=settings.deformations)
        setups.append(time.perf_counter() - t1)
        res = solve_static(model, problem=prob,
                           options=StaticOptions(max_iter=20, tol=1e-8, n_steps=n_steps))
        totals.append(prob.timings.total)
        timings.append(prob.timings)
    best = timings[totals.index(min(totals))]
    its = max(best.iterations, 1)
    tip = res.steps[-1].x[prob.num.pos_idx[-1]]
    return dict(case=case, n=n, unknowns=prob.pattern.n, setup=parse + min(setups),
                total=min(totals), median=statistics.median(totals),
                iterations=best.iterations, factorizations=best.factorizations,
                per_iter=best.total / its, kernels=best.kernels / its,
                assembly=best.assembly / its, solve=best.solve / its,
                other=(best.total - best.kernels - best.assembly - best.solve) / its,
                result=float(tip[1]), peak_mb=_peak_mb())


def _eigen_row(n: int, repeat: int) -> dict:
    from spacarpy.solvers.linear.eigen import ELASTIC, eigenmodes
    from spacarpy.solvers.linear.linearize import MassAssembler, linearize
    from spacarpy.solvers.statics.static import StaticProblem
    t0 = time.perf_counter()
    model, settings = job_from_text(eigen_cantilever_deck(n), f"<eigen cantilever {n}>")
    prob = StaticProblem(model, deformations=settings.deformations)
    mass = MassAssembler(model, prob.num, rotary=settings.rotary_inertia)
    setup = time.perf_counter() - t0
    x, mu = prob.num.x0.copy(), np.zeros(prob.num.n_constraint)
    load = prob.loads.at(0.0, 0.0)
    totals = []
    for _ in range(max(repeat, 1)):
        t1 = time.perf_counter()
        lin = linearize(prob, x, mu, load, mass=mass)
        md = eigenmodes(lin, prob.num, prob.free, n_modes=10)
        totals.append(time.perf_counter() - t1)
    f = np.sort(md.frequency[md.kind == ELASTIC])
    return dict(case="eigen", n=n, unknowns=prob.pattern.n, setup=setup, total=min(totals),
                median=statistics.median(totals), f1=float(f[0]) if f.size else np.nan,
                f10=float(f[min(9, f.size - 1)]) if f.size else np.nan,
                result=float(f[0]) if f.size else np.nan, peak_mb=_peak_mb())


def _transient_row(n: int, n_steps: int) -> dict:
    from spacarpy.solvers.dynamics.transient import TimeFunction, TransientOptions, solve_transient
    t0 = time.perf_counter()
    model, settings = job_from_text(transient_cantilever_deck(n, n_steps),
                                    f"<transient cantilever {n}>")
    setup = time.perf_counter() - t0
    opts = TransientOptions(t_end=settings.transient.timestep[0], n_steps=n_steps, rho_inf=0.5,
                            tol=1e-8, phi=TimeFunction(*settings.transient.time_function))
    t1 = time.perf_counter()
    res = solve_transient(model, opts)
    total = time.perf_counter() - t1
    steps = max(res.n_steps_taken, 1)
    tip = res.steps[-1].x[res.problem.num.pos_idx[-1]]
    return dict(case="transient", n=n, unknowns=res.problem.pattern.n, setup=setup,
                total=total, median=total, steps=steps, iterations=res.n_newton,
                per_step=total / steps, iters_per_step=res.n_newton / steps,
                lu_per_step=res.n_matrices / steps,
                per_iter=total / max(res.n_newton, 1), result=float(tip[1]),
                peak_mb=_peak_mb())


def arclength_deck(n: int) -> str:
    """The bench column of the arc-length case (see the module docstring)."""
    from spacarpy.cases import arclength_column_deck
    return arclength_column_deck(n, ds0=0.02, tol=1e-6, ea=ARCLENGTH_EA,
                                 imperfection=ARCLENGTH_IMPERFECTION).replace(
        "ARCLENGTH 200 0.02", ARCLENGTH_LINE)


def convergence_order(history, floor: float = 0.0) -> float:
    """The order of convergence from the last three residuals (or increments) of a Newton
    history above ``10 * floor`` (round-off): ``log(r2/r1) / log(r1/r0)``; NaN with fewer
    than three."""
    h = [r for r in history if r > 10 * floor]
    if len(h) < 3:
        return float("nan")
    r0, r1, r2 = h[-3:]
    return float(np.log(r2 / r1) / np.log(r1 / r0))


def _arclength_row(n: int) -> dict:
    from spacarpy.solvers.path.arclength import ArcLengthPath, point_at
    from spacarpy.solvers.statics.static import StaticOptions, StaticProblem, solve_static
    t0 = time.perf_counter()
    model, settings = job_from_text(arclength_deck(n), f"<arclength column {n}>")
    prob = StaticProblem(model, deformations=settings.deformations)
    setup = time.perf_counter() - t0
    res = solve_static(model, settings, problem=prob)
    total = prob.timings.total
    points = len(res.steps) - 1
    its = sum(st.iterations for st in res.steps[1:])
    # one post-buckling point again, with a longer arc: the residual history's order
    opts = StaticOptions.from_settings(settings)
    path = ArcLengthPath(prob, opts, settings.static.arclength)
    k = min(range(len(res.steps)), key=lambda i: abs(res.steps[i].load_factor - 0.7))
    _, history = path.correct(point_at(path, res.steps[k]), 0.1)
    ev = prob.evaluate(res.steps[k].x, res.steps[k].mu, path.load(res.steps[k].load_factor))
    floor = prob.residual_norm(ev.r, ev.c, ev.f_int, ev.f_ext)[1]
    increments = list(path.increments)
    tip = res.steps[-1].x[prob.num.pos_idx[-1]]
    return dict(case="arclength", n=n, unknowns=prob.pattern.n, setup=setup, total=total,
                median=total, points=points, iterations=its,
                iters_per_point=its / max(points, 1), per_iter=total / max(its, 1),
                order=convergence_order(history, floor),
                order_dx=convergence_order(increments), floor=floor, result=float(tip[1]),
                peak_mb=_peak_mb())


def _peer_row(case: str, n: int, n_steps: int, transient_steps: int) -> dict:
    from spacarpy.peers import exudyn_cantilever as exu
    if case == "cantilever":
        r = exu.cantilever(n, n_steps=n_steps)
        value = r["tip"][1] if r["ok"] else np.nan
    elif case == "bend":
        r = exu.bend(n, n_steps=n_steps)
        value = r["tip_position"][1] if r["ok"] and r.get("tip_position") is not None \
            else np.nan
    elif case == "eigen":
        r = exu.eigenfrequencies(n, n_modes=10)
        value = float(np.sort(r["freqs"])[0]) if r["ok"] and r.get("freqs") is not None \
            else np.nan
    else:
        r = exu.transient(n, n_steps=transient_steps)
        value = r["tip"][1] if r["ok"] else np.nan
    return dict(total=r["total"] if r["ok"] else None, iterations=r.get("iterations"),
                result=float(value), ok=bool(r["ok"]), reason=r.get("reason", ""),
                peak_mb=r.get("peak_mb"))


def _spinup_peer_row(n: int, t_end: float) -> dict:
    """The spin-up's row from Exudyn (:func:`spacarpy.peers.exudyn_spinup.spinup`)."""
    from spacarpy.peers.exudyn_spinup import spinup
    from spacarpy.spinup import iteration_stats, summary_row
    r = spinup(n, t_end=t_end)
    if r.get("t") is None:                             # Exudyn missing
        return dict(ok=False, reason=r["reason"])
    r.update(iteration_stats(r["t"][1:], r["its"]))
    return summary_row(r)


def _run_row(case: str, n: int, repeat: int, n_steps: int, transient_steps: int) -> dict:
    from spacarpy.memory import keep_freed_memory
    keep_freed_memory()                 # as `spacarpy run` does (spacarpy.memory)
    if case in ("cantilever", "bend"):
        return _static_row(case, n, repeat, n_steps)
    if case == "eigen":
        return _eigen_row(n, repeat)
    if case == "arclength":
        return _arclength_row(n)
    return _transient_row(n, transient_steps)


#: Largest cantilever whose whole-process time is measured (a fresh process per repetition).
WHOLE_PROCESS_MAX = 1000
#: The peer's whole process: Python, numpy, Exudyn, the model and the solve, nothing else.
_PEER_SCRIPT = ("import sys\n"
                "from spacarpy.peers.exudyn_cantilever import cantilever\n"
                "r = cantilever(int(sys.argv[1]), n_steps=int(sys.argv[2]))\n"
                "sys.exit(0 if r['ok'] else 1)\n")


def _best_wall(cmd, repeat: int, cwd: str) -> float | None:
    """Best wall seconds of ``repeat`` runs of ``cmd`` (each a fresh process, after one
    untimed run); None if one fails.

    The processes may write Python's byte-code caches (``PYTHONDONTWRITEBYTECODE`` is
    dropped from their environment): an installed program has them, and without them every
    run would time compiling spacarpy's modules from source (about 0.1 s). The untimed run
    writes them and warms the file cache."""
    import os
    import subprocess
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    best = None
    for i in range(max(repeat, 1) + 1):
        t0 = time.perf_counter()
        proc = subprocess.run(cmd, cwd=cwd, stdin=subprocess.DEVNULL, env=env,
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        if i == 0:
            if proc.returncode != 0:
                return None
            continue
        wall = time.perf_counter() - t0
        if proc.returncode != 0:
            return None
        best = wall if best is None else min(best, wall)
    return best


def whole_process(n: int, n_steps: int, repeat: int = 3, peer: bool = False) -> dict:
    """Whole-process wall time of the cantilever case: ``spacarpy run`` on its deck as a
    subprocess (start-up, parsing, solve, result file), best of ``repeat``; with ``peer``
    also the Exudyn script solving the same problem as a subprocess. Keys ``spacarpy`` and
    ``peer`` (seconds, or None when the run failed or was not asked for)."""
    import tempfile
    from pathlib import Path

    from spacarpy.cases import cantilever_deck
    text = cantilever_deck(n, n_steps=n_steps, tol=1e-8, compact=True, shear=SHEAR)
    # its EXPECT lines hold the shear-rigid Table 1 tip, which GA = 10 EA misses (exit 4)
    text = "\n".join(line for line in text.splitlines()
                     if not line.lstrip().upper().startswith("EXPECT")) + "\n"
    with tempfile.TemporaryDirectory(prefix="spacarpy-bench-") as tmp:
        deck = Path(tmp) / f"cantilever_{n}.dat"
        deck.write_text(text)
        ours = _best_wall([sys.executable, "-m", "spacarpy", "run", str(deck), "-q", "-o",
                           str(Path(tmp) / "out.h5")], repeat, tmp)
        theirs = _best_wall([sys.executable, "-c", _PEER_SCRIPT, str(n), str(n_steps)],
                            repeat, tmp) if peer else None
    return {"spacarpy": ours, "peer": theirs}


def deck_case(case: str, repeat: int) -> dict:
    """Whole-process wall time of a :data:`DECK_CASES` case: its ``spacarpy`` command as a
    subprocess, ``repeat`` times (the sweep once: it is 21 runs itself); minimum and median.
    The decks are those of a source checkout (``decks/`` beside the package)."""
    import subprocess
    import tempfile
    from pathlib import Path

    decks = Path(__file__).resolve().parents[1] / "decks"
    words = [w.format(deck=decks) for w in DECK_CASES[case]]
    command = "spacarpy " + " ".join(w.replace(str(decks), "decks") for w in words)
    if not Path(words[1]).is_file():
        return dict(case=case, n=0, command=command,
                    error=f"no deck {words[1]} (the decks of a source checkout)")
    times = []
    with tempfile.TemporaryDirectory(prefix="spacarpy-bench-") as tmp:
        for _ in range(1 if case == "sweep" else max(repeat, 1)):
            t0 = time.perf_counter()
            proc = subprocess.run([sys.executable, "-m", "spacarpy", *words, "-q", "-o",
                                   str(Path(tmp) / "out.h5")], cwd=tmp,
                                  stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                  stderr=subprocess.PIPE, text=True)
            if proc.returncode != 0:
                return dict(case=case, n=0, command=command,
                            error=f"exit code {proc.returncode}: "
                                  f"{proc.stderr.strip().splitlines()[-1:]}")
            times.append(time.perf_counter() - t0)
    return dict(case=case, n=0, command=command, whole=min(times),
                median=statistics.median(times))


def _in_child(fn, *args):
    """Run ``fn(*args)`` in a fresh process (its own peak memory); exceptions become rows."""
    ctx = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(max_workers=1, mp_context=ctx) as ex:
        try:
            return ex.submit(fn, *args).result()
        except Exception as exc:                       # a failed solve is a table entry
            return {"error": f"{type(exc).__name__}: {exc}".splitlines()[0][:120]}


# ----------------------------------------------------------------------------------------
# tables
# ----------------------------------------------------------------------------------------
def _columns(case: str, peer: bool):
    """(header, width, format function) per column."""
    def f(key, fmt, scale=1.0):
        def get(r):
            v = r.get(key)
            if v is None or (isinstance(v, float) and np.isnan(v)):
                return "-"
            return format(v, fmt) if fmt == "d" else format(v * scale, fmt)
        return get
    if case in DECK_CASES:
        return [("command", 72, lambda r: r.get("command", "-")),
                ("whole min s", 11, f("whole", ".3f")), ("median s", 9, f("median", ".3f"))]
    if case == "spinup":                        # one whole run: solve and results file
        cols = [("elements", 9, f("n", "d")), ("run s", 8, f("total", ".2f")),
                ("steps", 6, f("steps", "d")), ("iters/step", 10, f("iters_per_step", ".2f")),
                ("its t>16s", 9, f("its_constant", ".2f")),
                ("ms/step", 8, f("per_step", ".2f", 1e3)),
                ("peak lag (m)", 12, f("result", ".4f")), ("t peak (s)", 10, f("t_peak", ".2f"))]
        if not peer:
            return cols
        return cols + [("Exudyn s", 9, lambda r: _peer_get(r, "total", ".3f")),
                       ("Exudyn its/step", 15, lambda r: _peer_get(r, "iters_per_step", ".2f")),
                       ("Exudyn its t>16s", 16, lambda r: _peer_get(r, "its_constant", ".2f")),
                       ("Exudyn peak (m)", 15, lambda r: _peer_get(r, "result", ".4f")),
                       ("Exudyn t peak (s)", 17, lambda r: _peer_get(r, "t_peak", ".2f")),
                       ("ratio", 6, _ratio)]
    cols = [("elements", 9, f("n", "d")), ("unknowns", 9, f("unknowns", "d")),
            ("setup s", 8, f("setup", ".2f")), ("solve min s", 11, f("total", ".3f")),
            ("median s", 9, f("median", ".3f"))]
    if case in ("cantilever", "bend"):
        cols += [("iters", 6, f("iterations", "d")), ("LU", 5, f("factorizations", "d")),
                 ("ms/iter", 8, f("per_iter", ".2f", 1e3)),
                 ("kernels", 8, f("kernels", ".2f", 1e3)),
                 ("assembly", 9, f("assembly", ".2f", 1e3)),
                 ("solve", 7, f("solve", ".2f", 1e3)), ("other", 7, f("other", ".2f", 1e3)),
                 ("tip y (m)" if case == "cantilever" else "tip y (m)", 11,
                  f("result", ".6f" if case == "cantilever" else ".4f"))]
    elif case == "eigen":
        cols += [("f1 (Hz)", 9, f("f1", ".4f")), ("f10 (Hz)", 9, f("f10", ".3f"))]
    elif case == "arclength":
        cols += [("points", 7, f("points", "d")), ("iters", 6, f("iterations", "d")),
                 ("iters/point", 11, f("iters_per_point", ".2f")),
                 ("ms/iter", 8, f("per_iter", ".2f", 1e3)), ("order r", 7, f("order", ".2f")),
                 ("order dx", 8, f("order_dx", ".2f")), ("r floor", 8, f("floor", ".0e")),
                 ("tip y (m)", 10, f("result", ".4f"))]
    else:
        cols += [("steps", 6, f("steps", "d")), ("iters/step", 10, f("iters_per_step", ".2f")),
                 ("LU/step", 7, f("lu_per_step", ".2f")),
                 ("ms/step", 8, f("per_step", ".2f", 1e3)),
                 ("ms/iter", 8, f("per_iter", ".2f", 1e3)),
                 ("tip u_y (m)", 11, f("result", ".6f"))]
    cols += [("peak MB", 8, f("peak_mb", ".0f"))]
    if case == "cantilever":
        cols += [("whole s", 8, f("whole", ".3f"))]
    if peer:
        unit = {"eigen": "f1 (Hz)", "bend": "tip y (m)"}.get(case, "tip u_y (m)")
        cols += [("Exudyn s", 9, lambda r: _peer_get(r, "total", ".3f")),
                 ("Exudyn its", 10, lambda r: _peer_get(r, "iterations", "d")),
                 (f"Exudyn {unit}", 16, lambda r: _peer_get(
                     r, "result", ".4f" if case in ("eigen", "bend") else ".6f")),
                 ("ratio", 6, _ratio)]
        if case == "cantilever":
            cols += [("Exudyn whole s", 14, lambda r: _peer_get(r, "whole", ".3f")),
                     ("whole ratio", 11, _whole_ratio)]
    return cols


def _peer_get(row, key, fmt):
    p = row.get("peer")
    if not p:
        return "-"
    if not p.get("ok"):
        return "n/a"
    v = p.get(key)
    return "-" if v is None or (isinstance(v, float) and np.isnan(v)) else format(v, fmt)


def _whole_ratio(row):
    """spacarpy's whole-process time over the peer's."""
    p = row.get("peer") or {}
    if row.get("whole") is None or not p.get("whole"):
        return "-"
    return f"{row['whole'] / p['whole']:.2f}"


def _ratio(row):
    p = row.get("peer")
    if not p or not p.get("ok") or not p.get("total") or row.get("total") is None:
        return "-"
    return f"{row['total'] / p['total']:.2f}"


def _text_table(case: str, rows: list[dict], peer: bool) -> list[str]:
    cols = _columns(case, peer)
    header = " ".join(f"{h:>{w}}" for h, w, _ in cols)
    lines = [header, "-" * len(header)]
    for r in rows:
        if "error" in r:
            lines.append(f"{r.get('command') or r['n']:>9}  failed: {r['error']}")
            continue
        lines.append(" ".join(f"{get(r):>{w}}" for _, w, get in cols))
    return lines


def _markdown_table(case: str, rows: list[dict], peer: bool) -> list[str]:
    cols = _columns(case, peer)
    lines = ["| " + " | ".join(h for h, _, _ in cols) + " |",
             "|" + "|".join("---:" for _ in cols) + "|"]
    for r in rows:
        if "error" in r:
            lines.append(f"| {r.get('command') or r['n']} | failed: {r['error']} |"
                         + " |" * (len(cols) - 2))
            continue
        lines.append("| " + " | ".join(get(r) for _, _, get in cols) + " |")
    notes = [f"- {r['n']} elements, Exudyn: {r['peer']['reason']}" for r in rows
             if r.get("peer") and not r["peer"].get("ok") and r["peer"].get("reason")]
    return lines + ([""] + notes if notes else [])


def machine_summary() -> str:
    import numpy
    import scipy
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    import os

    from spacarpy import __version__
    return (f"spacarpy {__version__}, Python {platform.python_version()}, numpy "
            f"{numpy.__version__}, scipy {scipy.__version__}; {cpu}, {os.cpu_count()} cores")


def run_bench(cases=CASES + tuple(DECK_CASES), sizes=None, n_steps: int = 10,
              repeat: int = 3, transient_steps: int = 1000, peer: str | None = None,
              markdown: str | None = None, out=None, spinup_t_end: float = 30.0) -> dict:
    """Run the benchmark; print one table per case to ``out`` (default: the current
    sys.stdout) and write them as Markdown. ``spinup_t_end``: the spin-up's end time (s)."""
    out = sys.stdout if out is None else out
    if peer not in (None, "exudyn"):
        raise ValueError(f"unknown peer {peer!r} (known: exudyn)")
    if peer:
        from spacarpy.peers.exudyn_cantilever import available
        ok, version = available()
        if not ok:
            print(f"peer exudyn not available ({version}); install it with "
                  "pip install 'spacarpy[bench]'", file=out)
            peer = None
        else:
            print(f"peer: Exudyn {version}", file=out)
    print(machine_summary(), file=out)
    results = {}
    for case in cases:
        print("\n" + _title(case, transient_steps, spinup_t_end), file=out)
        if case in DECK_CASES:
            rows = [deck_case(case, repeat)]
            print("\n".join(_text_table(case, rows, False)), file=out)
            out.flush()
            results[case] = rows
            continue
        case_sizes = sizes.get(case, DEFAULT_SIZES[case]) if isinstance(sizes, dict) \
            else (sizes or DEFAULT_SIZES[case])
        rows = []
        head_printed = False
        for n in case_sizes:
            if case == "spinup":                    # one run: it takes seconds
                from spacarpy import spinup
                row = _in_child(spinup.bench_row, n, spinup_t_end)
                if peer:
                    row["peer"] = _in_child(_spinup_peer_row, n, spinup_t_end)
            else:
                # one repetition from 10^5 elements on, where a static solve takes a
                # minute; the eigen case keeps two, so that its minimum is, as at every
                # other size, a solve after the first (whose first touch of a few GB of
                # new memory costs seconds of page faults at 10^5 elements alone)
                reps = repeat if n < 100000 else (min(repeat, 2) if case == "eigen" else 1)
                row = _in_child(_run_row, case, n, reps, n_steps, transient_steps)
            row.setdefault("n", n)
            row.setdefault("case", case)
            # arclength: no Exudyn counterpart; spinup: its peer row above
            if peer and case not in ("arclength", "spinup"):
                row["peer"] = _in_child(_peer_row, case, n, n_steps, transient_steps)
            if "error" in row.get("peer", {}):
                row["peer"] = dict(ok=False, reason=row["peer"]["error"])
            if case == "cantilever" and n <= WHOLE_PROCESS_MAX:
                whole = whole_process(n, n_steps, repeat, bool(peer))
                row["whole"] = whole["spacarpy"]
                if peer:
                    row["peer"]["whole"] = whole["peer"]
            rows.append(row)
            lines = _text_table(case, [row], bool(peer))
            if not head_printed:
                print("\n".join(lines[:2]), file=out)
                head_printed = True
            print(lines[2], file=out)
            out.flush()
        results[case] = rows
    if markdown:
        write_markdown(markdown, results, bool(peer), n_steps, transient_steps, spinup_t_end)
        print(f"\nwrote {markdown}", file=out)
    return results


def _title(case: str, transient_steps: int, spinup_t_end: float = 30.0) -> str:
    return TITLES[case].format(steps=transient_steps, t_end=spinup_t_end)


#: The generated part of docs/performance.md lies between these lines; the rest of the page
#: is written by hand and kept.
MARKDOWN_BEGIN = "<!-- spacarpy bench: generated tables begin -->"
MARKDOWN_END = "<!-- spacarpy bench: generated tables end -->"


def write_markdown(path: str, results: dict, peer: bool, n_steps: int, transient_steps: int,
                   spinup_t_end: float = 30.0):
    """Write the tables into the Markdown page ``path`` (docs/performance.md): between
    :data:`MARKDOWN_BEGIN` and :data:`MARKDOWN_END` where the page has them (the page's
    hand-written text, what the columns mean and what was measured beyond the tables, is
    kept), else a new page with the tables alone."""
    from pathlib import Path
    parts = [f"Generated by `spacarpy bench` on {datetime.date.today().isoformat()} "
             f"({machine_summary()}). Do not edit the tables by hand: run the command "
             f"again.\n"]
    for case, rows in results.items():
        parts.append(f"## {_title(case, transient_steps, spinup_t_end)}\n")
        parts.append("\n".join(_markdown_table(case, rows, peer)) + "\n")
    block = "\n".join([MARKDOWN_BEGIN, *parts, MARKDOWN_END])
    page = Path(path)
    old = page.read_text() if page.exists() else ""
    if MARKDOWN_BEGIN in old and MARKDOWN_END in old:
        head, rest = old.split(MARKDOWN_BEGIN, 1)
        text = head + block + rest.split(MARKDOWN_END, 1)[1]
    else:
        text = "# Performance\n\n" + block + "\n"
    page.write_text(text)
