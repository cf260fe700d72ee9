"""``spacarpy bench``: time the solvers on cantilevers and a bend of growing size.

Cases (all in :mod:`spacarpy.bench.cases` terms, modified deformations):

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
    (:func:`spacarpy.bench.cases.arclength_column_deck`: 1.5 times the Euler load with a lateral
    imperfection of 1e-2, EA = 1e4 EI, ``ARCLENGTH 400 0.02 1e-4 0.02``, Newton to 1e-6):
    the points, the Newton iterations per point, and the order of convergence measured on
    the residual history (above 10 times its round-off floor, which grows with the stiffest
    element's stiffness) and on the increments of one post-buckling point (an arc length of
    0.1 from the point at load factor 0.7; 2 is quadratic).
``spinup``
    Simo & Vu-Quoc's spin-up (:mod:`spacarpy.bench.spinup`: ``decks/spinup_beam.dat`` with ``n``
    elements, h = 0.05 s, rho_inf = 0.5, final rate 4 rad/s, to ``spinup_t_end`` = 30 s, every
    step stored): wall time of the whole run (solve and results file), time steps, Newton
    iterations per step (mean over all steps and over t > 16 s at constant speed), and the
    tip's peak lag in the rotating frame; with ``--peer exudyn`` Exudyn's 2D geometrically
    exact beam on the same problem (:mod:`spacarpy.bench.peers.exudyn_spinup`).
``pendulum``, ``sweep``
    Whole processes on shipped decks (:data:`DECK_CASES`): ``spacarpy run
    decks/pendulum_rigid_90deg.dat`` (a rigid pendulum, 440 transient steps) and ``spacarpy
    sweep decks/leafspring_guidance_sweep.dat --set phi=0:0.002:21 -j 2`` (21 points).

Every (case, size) runs in a fresh process, so that its peak memory (the process's maximum
resident set) is its own; inside it the solve is repeated and the minimum and median are
shown. Set-up (deck parsing, numbering, sparsity pattern) is timed apart from the solve. The
static tables split the time per Newton iteration into element kernels, assembly, sparse
factorizations and solves, and the rest (norms, bookkeeping). With ``--peer exudyn`` the same
problems are solved by Exudyn (:mod:`spacarpy.bench.peers.exudyn_cantilever`) in the same run,
and the ratio of the solve times (spacarpy / Exudyn) is shown with the result each code reaches;
``--peer opensees`` does the same for the lattice with OpenSees
(:mod:`spacarpy.bench.peers.opensees_lattice`). The cantilever rows up to
:data:`WHOLE_PROCESS_MAX` elements also time the whole process (:func:`whole_process`):
``spacarpy run`` as a subprocess against the Exudyn script as a subprocess, best of
``repeat``.
``--markdown FILE`` writes the tables as docs/performance.md is made. Nothing else is written;
numbers are never asserted in tests.

The case names, sizes and decks are in :mod:`spacarpy.bench.decks`, the tables in
:mod:`spacarpy.bench.tables`.
"""
from __future__ import annotations

import gc
import multiprocessing
import resource
import statistics
import sys
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from spacarpy.bench.decks import (
    CASES,
    DECK_CASES,
    DEFAULT_SIZES,
    LATTICE,
    PEERS,
    SHEAR,
    arclength_deck,
    eigen_cantilever_deck,
    lattice_deck,
    lattice_elements,
    lattice_grid,
    lattice_node,
    transient_cantilever_deck,
)
from spacarpy.bench.tables import (
    _text_table,
    _title,
    machine_summary,
    peer_name,
    write_markdown,
)
from spacarpy.deck import job_from_text
from spacarpy.memory import estimate_run_bytes
from spacarpy.solvers.linalg.pardiso import factor_high_water


# ----------------------------------------------------------------------------------------
# one (case, size), run inside a child process
# ----------------------------------------------------------------------------------------
def _peak_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def _static_row(case: str, n: int, repeat: int, n_steps: int) -> dict:
    from spacarpy.bench.cases import bend_deck, cantilever_deck
    from spacarpy.solvers.statics.static import StaticOptions, StaticProblem, solve_static
    grid = None
    if case == "lattice":                       # n: the target number of beams
        grid = lattice_grid(n)
        text, n_steps = lattice_deck(*grid), LATTICE["steps"]
    elif case == "cantilever":
        text = cantilever_deck(n, n_steps=n_steps, tol=1e-8, compact=True, shear=SHEAR)
    else:
        text = bend_deck(n, n_steps=n_steps, tol=1e-8)
    t0 = time.perf_counter()
    model, settings = job_from_text(text, f"<{case} {n}>")
    parse = time.perf_counter() - t0
    totals, timings, setups, factor_bytes = [], [], [], []
    for _ in range(max(repeat, 1)):
        prob = None
        gc.collect()                            # the last repetition's factorizations
        factor_high_water(reset=True)
        t1 = time.perf_counter()
        prob = StaticProblem(model, deformations=settings.deformations)
        setups.append(time.perf_counter() - t1)
        res = solve_static(model, problem=prob,
                           options=StaticOptions(max_iter=20, tol=1e-8, n_steps=n_steps))
        totals.append(prob.timings.total)
        timings.append(prob.timings)
        factor_bytes.append(factor_high_water())
    best = timings[totals.index(min(totals))]
    its = max(best.iterations, 1)
    tip = res.steps[-1].x[prob.num.pos_idx[-1]]
    if grid is not None:                        # the mean u_x of the top nodes
        top = [lattice_node(grid[0], grid[1], i, j, grid[2] - 1)
               for j in range(grid[1]) for i in range(grid[0])]
        ux = lattice_top_ux(model, prob, res.steps[-1].x, top)
        tip = np.array([0.0, ux, 0.0])
        n = lattice_elements(*grid)
    return dict(case=case, n=n, unknowns=prob.pattern.n,
                grid=grid and "x".join(map(str, grid)), setup=parse + min(setups),
                total=min(totals), median=statistics.median(totals),
                iterations=best.iterations, factorizations=best.factorizations,
                reuses=best.reuses,
                per_iter=best.total / its, kernels=best.kernels / its,
                assembly=best.assembly / its, solve=best.solve / its,
                other=(best.total - best.kernels - best.assembly - best.solve) / its,
                result=float(tip[1]), peak_mb=_peak_mb(),
                # the run's estimate: the per-element one plus the supernodal factors'
                # memory that their analyses reported (the largest sum alive at once)
                estimate_mb=(estimate_run_bytes(n) + max(factor_bytes)) / 2**20)


def lattice_top_ux(model, prob, x, top_nodes) -> float:
    """Mean displacement along x of the lattice's position nodes ``top_nodes`` at ``x``."""
    where = {int(p): k for k, p in enumerate(model.position_ids)}
    idx = prob.num.pos_idx[[where[p] for p in top_nodes], 0]
    return float(np.mean(x[idx] - prob.num.x0[idx]))


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


def _exudyn_lattice_row(n: int, limit: float | None) -> dict:
    """The lattice's Exudyn row: the converged answer from Exudyn's equations with 4 and 8
    beams per member, extrapolated in the mesh
    (:func:`spacarpy.bench.peers.exudyn_lattice.extrapolated`), and the time of Exudyn's own
    ``SolveStatic`` with 4 beams per member as a user runs it, a fresh process stopped after
    ``limit`` seconds (:func:`~spacarpy.bench.peers.exudyn_lattice.own_solve`): ``total``
    (solve alone) and ``whole`` (the process), or ``stopped`` and ``limit``. ``own_diff``
    (kept in the results, not shown in the table): the relative difference of that
    solve's answer from the answer's 4-beam solve (the comparison tests/test_lattice.py bounds by
    1e-10 on small lattices)."""
    from spacarpy.bench.peers.exudyn_lattice import MESH, extrapolated, own_solve
    grid = lattice_grid(n)
    answer = extrapolated(*grid)
    own = own_solve(*grid, mesh=MESH, limit=limit)
    coarse = (answer.get("coarse") or {}).get("top_ux", float("nan"))
    own_diff = (abs(own["top_ux"] / coarse - 1)
                if own.get("ok") and np.isfinite(coarse) else None)
    reason = answer.get("reason", "") if not answer["ok"] else own.get("reason", "")
    return dict(ok=bool(answer["ok"]), result=float(answer["top_ux"]), reason=reason,
                total=own.get("total") if own.get("ok") else None,
                whole=own.get("whole") if own.get("ok") else None,
                iterations=own.get("iterations"), stopped=own.get("stopped"),
                limit=own.get("limit"), peak_mb=own.get("peak_mb"), own_diff=own_diff,
                answer_s=answer.get("total"), meshes=answer.get("meshes"))


def _peer_row(case: str, n: int, n_steps: int, transient_steps: int,
              peer: str = "exudyn", peer_limit: float | None = None) -> dict:
    from spacarpy.bench.peers import exudyn_cantilever as exu
    if peer == "opensees":          # the lattice only (PEER_CASES)
        from spacarpy.bench.peers.opensees_lattice import lattice
        r = lattice(*lattice_grid(n))
        value = r["top_ux"]
    elif case == "lattice":
        return _exudyn_lattice_row(n, peer_limit)
    elif case == "cantilever":
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
    """The spin-up's row from Exudyn (:func:`spacarpy.bench.peers.exudyn_spinup.spinup`)."""
    from spacarpy.bench.peers.exudyn_spinup import spinup
    from spacarpy.bench.spinup import iteration_stats, summary_row
    r = spinup(n, t_end=t_end)
    if r.get("t") is None:                             # Exudyn missing
        return dict(ok=False, reason=r["reason"])
    r.update(iteration_stats(r["t"][1:], r["its"]))
    return summary_row(r)


def _run_row(case: str, n: int, repeat: int, n_steps: int, transient_steps: int) -> dict:
    from spacarpy.memory import keep_freed_memory
    keep_freed_memory()                 # as `spacarpy run` does (spacarpy.memory)
    if case in ("cantilever", "bend", "lattice"):
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
                "from spacarpy.bench.peers.exudyn_cantilever import cantilever\n"
                "r = cantilever(int(sys.argv[1]), n_steps=int(sys.argv[2]))\n"
                "sys.exit(0 if r['ok'] else 1)\n")


def whole_lattice(n: int, repeat: int = 3) -> float | None:
    """Whole-process wall time of ``spacarpy run`` on the lattice deck of about ``n`` beams
    (:func:`~spacarpy.bench.decks.lattice_deck`, its results file included), best of
    ``repeat``; None if the run failed. From :data:`LATTICE_WARM_MAX` beams on the run is
    not preceded by an untimed one (a minute or more; the file cache is warm by then)."""
    import tempfile
    from pathlib import Path
    with tempfile.TemporaryDirectory(prefix="spacarpy-bench-") as tmp:
        deck = Path(tmp) / f"lattice_{n}.dat"
        deck.write_text(lattice_deck(*lattice_grid(n)))
        return _best_wall([sys.executable, "-m", "spacarpy", "run", str(deck), "-q", "-o",
                           str(Path(tmp) / "out.h5")], repeat, tmp,
                          warm=n < LATTICE_WARM_MAX)


#: the largest lattice whose whole-process runs follow an untimed one (:func:`whole_lattice`)
LATTICE_WARM_MAX = 30000


def _best_wall(cmd, repeat: int, cwd: str, warm: bool = True) -> float | None:
    """Best wall seconds of ``repeat`` runs of ``cmd`` (each a fresh process, after one
    untimed run if ``warm``); None if one fails.

    The processes may write Python's byte-code caches (``PYTHONDONTWRITEBYTECODE`` is
    dropped from their environment): an installed program has them, and without them every
    run would time compiling spacarpy's modules from source (about 0.1 s). The untimed run
    writes them and warms the file cache."""
    import os
    import subprocess
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    best = None
    for i in range(0 if warm else 1, max(repeat, 1) + 1):
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

    from spacarpy.bench.cases import cantilever_deck
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


def deck_dirs() -> list:
    """Where the :data:`DECK_CASES` decks are looked for: ``decks/`` beside the package (an
    editable install or a checkout), then the current directory's ``decks/`` (a checkout
    after a non-editable ``pip install .``, which does not ship the decks)."""
    from pathlib import Path
    dirs = [Path(__file__).resolve().parents[2] / "decks", Path.cwd() / "decks"]
    return list(dict.fromkeys(dirs))


def deck_case(case: str, repeat: int) -> dict:
    """Whole-process wall time of a :data:`DECK_CASES` case: its ``spacarpy`` command as a
    subprocess, ``repeat`` times (the sweep once: it is 21 runs itself); minimum and median.
    The decks are those of a source checkout (:func:`deck_dirs`)."""
    import subprocess
    import tempfile
    from pathlib import Path

    name = Path(DECK_CASES[case][1]).name
    dirs = deck_dirs()
    decks = next((d for d in dirs if (d / name).is_file()), None)
    command = "spacarpy " + " ".join(w.format(deck="decks") for w in DECK_CASES[case])
    if decks is None:
        return dict(case=case, n=0, command=command,
                    error=f"no deck {name}: this case runs a deck of spacarpy's source "
                          f"checkout; looked in {' and '.join(map(str, dirs))} (run bench in "
                          "the checkout's directory, or leave the case out with --cases)")
    words = [w.format(deck=decks) for w in DECK_CASES[case]]
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




def run_bench(cases=CASES + tuple(DECK_CASES), sizes=None, n_steps: int = 10,
              repeat: int = 3, transient_steps: int = 1000, peer: str | None = None,
              markdown: str | None = None, out=None, spinup_t_end: float = 30.0,
              peer_limit: float | None = None) -> dict:
    """Run the benchmark; print one table per case to ``out`` (default: the current
    sys.stdout) and write them as Markdown. ``spinup_t_end``: the spin-up's end time (s);
    ``peer_limit``: the wall seconds after which Exudyn's own lattice solve is stopped (its
    time is then shown as a lower bound; None: ``exudyn_lattice.OWN_LIMIT``)."""
    out = sys.stdout if out is None else out
    if peer not in (None, *PEERS):
        raise ValueError(f"unknown peer {peer!r} (known: {', '.join(PEERS)})")
    if peer:
        if peer == "opensees":
            from spacarpy.bench.peers.opensees_lattice import available
        else:
            from spacarpy.bench.peers.exudyn_cantilever import available
        ok, version = available()
        if not ok:
            print(f"peer {peer} not available ({version}); install it with "
                  "pip install 'spacarpy[bench]'", file=out)
            peer = None
        else:
            print(f"peer: {peer_name(peer)} {version}", file=out)
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
        # the case's peer: Exudyn has every case but arclength, OpenSees the lattice
        case_peer = peer if peer and case in PEERS[peer] else None
        for n in case_sizes:
            if case == "spinup":                    # one run: it takes seconds
                from spacarpy.bench import spinup
                row = _in_child(spinup.bench_row, n, spinup_t_end)
                if case_peer:
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
            # spinup: its peer row above
            if case_peer and case != "spinup":
                row["peer"] = _in_child(_peer_row, case, n, n_steps, transient_steps,
                                        case_peer, peer_limit)
            if "error" in row.get("peer", {}):
                row["peer"] = dict(ok=False, reason=row["peer"]["error"])
            if case == "lattice" and case_peer:
                row["whole"] = whole_lattice(n, reps)
            if case == "cantilever" and n <= WHOLE_PROCESS_MAX:
                whole = whole_process(n, n_steps, repeat, bool(case_peer))
                row["whole"] = whole["spacarpy"]
                if case_peer:
                    row["peer"]["whole"] = whole["peer"]
            rows.append(row)
            lines = _text_table(case, [row], case_peer or False)
            if not head_printed:
                print("\n".join(lines[:2]), file=out)
                head_printed = True
            print(lines[2], file=out)
            out.flush()
        results[case] = rows
    failed = failed_rows(results)
    if markdown and failed:         # a failed row is never written into the page
        print(f"\n{markdown} not written: {len(failed)} case(s) failed", file=out)
    elif markdown:
        write_markdown(markdown, results, peer or False, n_steps, transient_steps,
                       spinup_t_end)
        print(f"\nwrote {markdown}", file=out)
    return results


def failed_rows(results: dict) -> list:
    """The rows of :func:`run_bench`'s results that failed (an ``error``), the peer's
    excepted (a missing or failing peer is reported in its column)."""
    return [r for rows in results.values() for r in rows if "error" in r]

