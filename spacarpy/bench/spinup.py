"""Simo & Vu-Quoc's spin-up of a flexible beam: the deck, a spacarpy run, the tip's lag, and
the ``spinup`` case of ``spacarpy bench``.

The problem of ``decks/spinup_beam.dat`` (Simo & Vu-Quoc 1986, Part II): a beam of L = 10 m
clamped to a hub at the origin, turned about z by the prescribed angle ``rate * phi(t)``
with ``TIMEFUNCTION spinup T`` (T = 15 s: the rate rises smoothly from 0 to ``rate`` and
then stays constant). :func:`spinup_deck` writes that deck with the mesh, the step, the
spectral radius and the final rate as parameters, storing every step. :func:`run_spacarpy`
runs it and returns the tip's lag in the hub's rotating frame
(:func:`spacarpy.results.rotating.displacement_in_frame`) with the Newton iterations of every
step; :func:`lag_summary` reduces a lag history to the numbers compared with Exudyn
(:mod:`spacarpy.bench.peers.exudyn_spinup`) in ``tests/test_spinup_validation.py`` and
docs/transient.md. :func:`bench_row` is the bench's row (the Exudyn row is made in
:mod:`spacarpy.bench`, which imports both codes).
"""
from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np

from spacarpy.time_functions import TimeFunction

#: the deck's data: L (m), EA (N), EI = GJ (N m^2), rho A (kg/m), rho (Iy + Iz), rho Iy,
#: rho Iz (kg m), the spin-up time T (s)
BEAM = dict(L=10.0, EA=2.8e7, EI=1.4e4, GJ=1.4e4, rhoA=1.2, rhoIp=1.2e-3, rhoIy=6e-4,
            rhoIz=6e-4, T=15.0)
#: the lag's oscillation after the spin-up is measured from this time on (s)
T_SETTLED = 20.0
#: iterations per step "at constant speed" are averaged from this time on (s)
T_CONSTANT = 16.0
#: node numbers of the deck: the hub's position and orientation nodes, the tip
HUB, HUB_FRAME, TIP = 1, 2, 3


def spinup_phi() -> TimeFunction:
    """phi(t) of the deck's ``TIMEFUNCTION spinup 15`` (the solver's own function)."""
    return TimeFunction("spinup", (BEAM["T"],))


def spinup_deck(n: int = 10, h: float = 0.05, rho_inf: float = 0.5, rate: float = 4.0,
                t_end: float = 30.0) -> str:
    """decks/spinup_beam.dat with ``n`` elements, step ``h``, ``RHOINF rho_inf``, final rate
    ``rate`` (rad/s), to ``t_end``, every step stored (``round(t_end / h)`` equal steps)."""
    n_steps = int(round(t_end / h))
    b = BEAM
    return "\n".join([
        "# Simo & Vu-Quoc's spin-up (spacarpy.bench.spinup.spinup_deck; decks/spinup_beam.dat)",
        "MODE transient", f"RHOINF {rho_inf!r}", f"TIMEFUNCTION spinup {b['T']:g}",
        f"SET n {int(n)}", f"SET L {b['L']:g}", "X 1 0 0 0", "X 3 {L} 0 0",
        "BEAMS 1 1 2 3 4 {n} 0 1 0", "DYNE 1:{n} 1 2 3 4 5 6", "INPUTR 2 0 0 1", "FIX 1",
        "END", "HALT",
        f"ESTIFF 1:{{n}} {b['EA']:g} {b['GJ']:g} {b['EI']:g} {b['EI']:g}",
        f"EM 1:{{n}} {b['rhoA']:g} {b['rhoIp']:g} {b['rhoIy']:g} {b['rhoIz']:g} 0",
        f"DELINPR 2 {rate!r}", f"TIMESTEP {float(t_end)!r} {n_steps}", "SUBSTEPS 1",
        "END", "END", ""])


def lag_summary(t, lag, t_end: float | None = None) -> dict:
    """``peak`` (m, the most negative lag during the spin-up t <= T) and ``t_peak`` (s), both
    from the parabola through the lowest sample and its two neighbours (the sampled minimum
    alone would quantize the time to the step); ``amplitude``: the largest ``|lag|`` from
    :data:`T_SETTLED` on (NaN unless the history reaches ``t_end``, default its last time,
    and :data:`T_SETTLED`);
    ``t_reached``."""
    t, lag = np.asarray(t, dtype=float), np.asarray(lag, dtype=float)
    t_end = t[-1] if t_end is None else t_end
    out = dict(peak=np.nan, t_peak=np.nan, amplitude=np.nan,
               t_reached=float(t[-1]) if t.size else 0.0)
    during = np.flatnonzero(t <= BEAM["T"])
    if during.size >= 3:
        k = int(during[np.argmin(lag[during])])
        out["peak"], out["t_peak"] = float(lag[k]), float(t[k])
        if 0 < k < during[-1]:
            y0, y1, y2 = lag[k - 1:k + 2]
            curv = y0 - 2 * y1 + y2
            if curv > 0:
                d = 0.5 * (y0 - y2) / curv             # in steps, |d| <= 1/2
                out["peak"] = float(y1 - 0.25 * (y0 - y2) * d)
                out["t_peak"] = float(t[k] + d * 0.5 * (t[k + 1] - t[k - 1]))
    if t.size and t[-1] >= max(t_end - 1e-9 * max(t_end, 1.0), T_SETTLED):
        out["amplitude"] = float(np.abs(lag[t >= T_SETTLED]).max())
    return out


def iteration_stats(t, its) -> dict:
    """``its_mean`` over all steps and ``its_constant`` over the steps ending after
    :data:`T_CONSTANT` (NaN if none); ``t`` the end time of each step."""
    t, its = np.asarray(t, dtype=float), np.asarray(its, dtype=float)
    n = min(t.size, its.size)                 # a failed run: its may hold the failed step
    t, its = t[:n], its[:n]
    late = its[t > T_CONSTANT]
    return dict(its_mean=float(its.mean()) if its.size else np.nan,
                its_constant=float(late.mean()) if late.size else np.nan)


def run_spacarpy(n: int = 10, h: float = 0.05, rho_inf: float = 0.5, rate: float = 4.0,
                 t_end: float = 30.0, out: str | Path | None = None) -> dict:
    """Run :func:`spinup_deck` (a results file ``out``, else a temporary one): ``t``, ``lag``
    and ``radial`` (the tip's displacement across and along the hub's x axis, m) at every
    step, t = 0 included; ``its`` (Newton iterations of each step),
    ``total`` (wall s of the run: solve and results file), ``steps``, ``iterations``,
    ``ok``, ``reason`` (the error of a failed run, whose completed steps are still read),
    :func:`lag_summary` and :func:`iteration_stats`."""
    from spacarpy.deck import job_from_text
    from spacarpy.errors import SpacarError
    from spacarpy.results import open_results
    from spacarpy.results.h5file import partial_path_for
    from spacarpy.results.rotating import displacement_in_frame
    from spacarpy.run import run_job

    job = job_from_text(spinup_deck(n, h, rho_inf, rate, t_end), "<spin-up>")
    with tempfile.TemporaryDirectory(prefix="spacarpy-spinup-") as tmp:
        path = Path(out) if out is not None else Path(tmp) / "spinup.h5"
        reason = ""
        t0 = time.perf_counter()
        try:
            run_job(job, path)
        except SpacarError as exc:
            reason = str(exc).splitlines()[0]
        total = time.perf_counter() - t0
        if reason and not path.exists():        # a failed run keeps its steps here
            path = partial_path_for(path)
        with open_results(path) as res:
            t, d = displacement_in_frame(res, TIP, HUB_FRAME, HUB)
            its = np.asarray(res.transient.iterations, dtype=float)[1:]
    lag = d[:, 1]
    return dict(ok=not reason, reason=reason, total=total, steps=int(its.size),
                iterations=int(its.sum()), t=t, lag=lag, radial=d[:, 0], its=its, n=n, h=h,
                rho_inf=rho_inf, rate=rate, **lag_summary(t, lag, t_end=t_end),
                **iteration_stats(t[1:], its))


def bench_row(n: int, t_end: float = 30.0, h: float = 0.05, rho_inf: float = 0.5,
              rate: float = 4.0) -> dict:
    """One row of ``spacarpy bench``'s spin-up table (spacarpy)."""
    r = run_spacarpy(n, h, rho_inf, rate, t_end)
    if not r["ok"]:
        raise RuntimeError(f"{r['reason']} (t = {r['t_reached']:g} s reached)")
    return summary_row(r)


def summary_row(r: dict) -> dict:
    """A bench row from :func:`run_spacarpy`'s result, or the Exudyn peer's with
    :func:`iteration_stats` added."""
    steps = max(int(r["steps"]), 1)
    return dict(case="spinup", n=r["n"], total=r["total"], median=r["total"],
                steps=int(r["steps"]), iterations=int(r["iterations"]),
                iters_per_step=r["iterations"] / steps, its_constant=r["its_constant"],
                per_step=r["total"] / steps, result=r["peak"], t_peak=r["t_peak"],
                amplitude=r["amplitude"], ok=bool(r["ok"]), reason=r.get("reason", ""))
