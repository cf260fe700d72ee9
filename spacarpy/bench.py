"""``spacarpy bench``: time static solves of straight cantilevers of growing size.

Case: the Table 1 cantilever (tip force 3EI/L^2, a large deflection) with n elements,
modified deformations, 10 load steps. For each size the table shows the whole solve (min
and median over the repetitions, in one process) and the time per Newton iteration split
into element kernels, assembly, sparse LU solve and the rest (residual norms, bookkeeping).
Set-up (deck parsing, numbering, sparsity pattern) is timed separately. Nothing is written.

Transient case (:func:`run_transient_bench`): the same cantilever (steel, 0.1 m square,
rho = 7850 kg/m^3 with rotary inertia) at rest, a tenth of the tip force raised smoothly in
20 ms, ``n_steps`` generalized-alpha steps of 1 ms (rho_inf = 0.5): time per step, Newton
iterations per step and the tip deflection reached.
"""
from __future__ import annotations

import resource
import statistics
import sys
import time

from spacarpy.cases import cantilever_deck
from spacarpy.deck import build_model, parse_deck
from spacarpy.solvers.static import StaticOptions, StaticProblem, solve_static
from spacarpy.solvers.transient import TimeFunction, TransientOptions, solve_transient


def run_bench(sizes=(10, 100, 1000, 10000), n_steps: int = 10, repeat: int = 3,
              out=sys.stdout) -> list[dict]:
    rows = []
    header = (f"{'elements':>9} {'unknowns':>9} {'setup s':>8} {'solve min s':>11} "
              f"{'median s':>9} {'iters':>6} {'ms/iter':>8} {'kernels':>8} {'assembly':>9} "
              f"{'solve':>7} {'other':>7} {'tip u_y (m)':>12} {'peak MB':>8}")
    print("static cantilever (Table 1 load, modified deformations, "
          f"{n_steps} load steps); per-iteration columns in ms", file=out)
    print(header, file=out)
    print("-" * len(header), file=out)
    for n in sizes:
        text = cantilever_deck(n, n_steps=n_steps, tol=1e-8)
        t0 = time.perf_counter()
        model = build_model(parse_deck(text, f"<cantilever {n}>"), text=text,
                            path=f"<cantilever {n}>")
        setup_parse = time.perf_counter() - t0
        totals, timings = [], []
        for _ in range(max(repeat, 1)):
            t1 = time.perf_counter()
            prob = StaticProblem(model)
            setup = time.perf_counter() - t1
            opts = StaticOptions(max_iter=20, tol=1e-8, n_steps=n_steps)
            res = solve_static(model, problem=prob, options=opts)
            totals.append(prob.timings.total)
            timings.append(prob.timings)
        best = timings[totals.index(min(totals))]
        its = max(best.iterations, 1)
        other = best.total - best.kernels - best.assembly - best.solve
        tip = res.steps[-1].x[prob.num.pos_idx[-1]]
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        row = dict(n_elem=n, n_unknown=prob.pattern.n, setup=setup_parse + setup,
                   total_min=min(totals), total_median=statistics.median(totals),
                   iterations=best.iterations, per_iter=best.total / its,
                   kernels=best.kernels / its, assembly=best.assembly / its,
                   solve=best.solve / its, other=other / its, tip_uy=float(tip[1]),
                   peak_mb=peak)
        rows.append(row)
        print(f"{n:>9d} {row['n_unknown']:>9d} {row['setup']:>8.2f} {row['total_min']:>11.3f} "
              f"{row['total_median']:>9.3f} {row['iterations']:>6d} "
              f"{1e3 * row['per_iter']:>8.2f} {1e3 * row['kernels']:>8.2f} "
              f"{1e3 * row['assembly']:>9.2f} {1e3 * row['solve']:>7.2f} "
              f"{1e3 * row['other']:>7.2f} {row['tip_uy']:>12.6f} {peak:>8.0f}", file=out)
        out.flush()
    return rows


def transient_cantilever_deck(n: int, n_steps: int, dt: float = 1e-3) -> str:
    """The bench cantilever as a transient deck: at rest, the tip force from t = 0 on."""
    text = cantilever_deck(n, n_steps=1, tol=1e-8)
    rho, a = 7850.0, 0.1
    em = f"EM 1:{n} {rho * a * a!r} {rho * a**4 / 6!r} {rho * a**4 / 12!r} {rho * a**4 / 12!r} 0"
    lines = [ln for ln in text.splitlines() if not ln.startswith("EXPECT")]
    text = "\n".join(lines).replace("MODE static", "MODE transient\nRHOINF 0.5")
    # a tenth of Table 1's force, raised smoothly over 20 ms (a sudden load would send a
    # stress wave through the fine meshes that 1 ms steps cannot follow): a deflection of a
    # few cm, vibrating at the first frequency (about 21 Hz, 48 steps of 1 ms per period)
    text = text.replace(" 1293750 0", " 129375 0").replace(
        "RHOINF 0.5", "RHOINF 0.5\nTIMEFUNCTION smoothstep 0.02")
    return text.replace("ITERSTEP 20 1 1e-08",
                        f"{em}\nITERSTEP 20 1 1e-08\nTIMESTEP {n_steps * dt!r} {n_steps}")


def run_transient_bench(sizes=(100, 1000), n_steps: int = 100, out=sys.stdout) -> list[dict]:
    rows = []
    header = (f"{'elements':>9} {'steps':>6} {'total s':>8} {'ms/step':>8} {'iters/step':>10} "
              f"{'ms/iter':>8} {'tip u_y (m)':>12}")
    print(f"\ntransient cantilever (tip force raised in 20 ms, {n_steps} steps of 1 ms, "
          "rho_inf = 0.5)", file=out)
    print(header, file=out)
    print("-" * len(header), file=out)
    for n in sizes:
        text = transient_cantilever_deck(n, n_steps)
        model = build_model(parse_deck(text, f"<transient cantilever {n}>"), text=text,
                            path=f"<transient cantilever {n}>")
        opts = TransientOptions(t_end=model.timestep[0], n_steps=n_steps, rho_inf=0.5,
                                tol=1e-8, phi=TimeFunction(*model.time_function))
        t0 = time.perf_counter()
        res = solve_transient(model, opts)
        total = time.perf_counter() - t0
        steps = max(res.n_steps_taken, 1)
        tip = res.steps[-1].x[res.problem.num.pos_idx[-1]]
        row = dict(n_elem=n, steps=steps, total=total, per_step=total / steps,
                   iters_per_step=res.n_newton / steps,
                   per_iter=total / max(res.n_newton, 1), tip_uy=float(tip[1]))
        rows.append(row)
        print(f"{n:>9d} {steps:>6d} {total:>8.2f} {1e3 * row['per_step']:>8.2f} "
              f"{row['iters_per_step']:>10.2f} {1e3 * row['per_iter']:>8.2f} "
              f"{row['tip_uy']:>12.6f}", file=out)
        out.flush()
    return rows
