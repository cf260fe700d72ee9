"""docs/spinup_lag.png and the rows of the spin-up table in docs/transient.md.

Not a test module (pytest collects test_*.py only): ``python tests/spinup_figure.py`` runs
Simo & Vu-Quoc's spin-up with spacarpy (10 elements) and Exudyn (20 elements) at the cases of
tests/test_spinup_validation.py, prints one Markdown row per run (peak lag, time of the peak,
largest |lag| after t = 20 s, Newton iterations per step) and draws the lag against time of
both codes at h = 0.05 s, rho_inf = 0.5 (4 and 6 rad/s) into docs/spinup_lag.png. Needs
Exudyn and matplotlib; about a minute.
"""
from __future__ import annotations

import sys
from pathlib import Path

from spacarpy.bench.peers.exudyn_spinup import spinup
from spacarpy.bench.spinup import iteration_stats, run_spacarpy

CASES = [(4.0, 0.05, 0.5), (6.0, 0.05, 0.5), (4.0, 0.1, 0.5)]
FIGURE = Path(__file__).resolve().parents[1] / "docs" / "spinup_lag.png"


def _row(code, n, r):
    stats = iteration_stats(r["t"][1:], r["its"])
    reached = "30" if r["ok"] else f"fails at {r['t_reached']:.3g} s"
    return (f"| {code} | {n} | {r['rate']:g} | {r['h']:g} | {r['rho_inf']:g} | {reached} | "
            f"{r['peak']:.5f} | {r['t_peak']:.3f} | {r['amplitude'] * 1e3:.2f} | "
            f"{stats['its_mean']:.2f}; {stats['its_constant']:.2f} |")


def main() -> int:
    runs = {}
    print("| code | elements | rate (rad/s) | h (s) | rho_inf | t reached (s) | peak lag (m) "
          "| t of peak (s) | max abs lag t > 20 s (mm) | its/step (all; t > 16 s) |")
    print("|---|---:|---:|---:|---:|---|---:|---:|---:|---|")
    for case in CASES:
        for code, n, f in (("spacarpy", 10, run_spacarpy), ("Exudyn", 20, spinup)):
            r = f(n, case[1], case[2], case[0])
            runs[code, case] = r
            print(_row(code, n, r), flush=True)
    import matplotlib
    matplotlib.use("Agg")
    from matplotlib.figure import Figure
    fig = Figure(figsize=(7.5, 3.0), dpi=100, layout="constrained")
    full, late = fig.subplots(1, 2, width_ratios=(1.4, 1.0))
    for case, color in (((4.0, 0.05, 0.5), "C0"), ((6.0, 0.05, 0.5), "C3")):
        for code, style in (("spacarpy", "-"), ("Exudyn", "--")):
            r = runs[code, case]
            label = f"{code}, {case[0]:g} rad/s"
            full.plot(r["t"], r["lag"], style, color=color, lw=1.2, label=label)
            m = r["t"] >= 15.0
            late.plot(r["t"][m], 1e3 * r["lag"][m], style, color=color, lw=1.0)
    full.set_xlabel("t (s)")
    full.set_ylabel("tip lag in the hub frame (m)")
    full.set_title("h = 0.05 s, rho_inf = 0.5", fontsize=9)
    full.legend(fontsize=7, loc="lower right")
    late.set_xlabel("t (s)")
    late.set_ylabel("lag (mm), t >= 15 s")
    for ax in (full, late):
        ax.grid(alpha=0.3)
        ax.tick_params(labelsize=8)
    fig.savefig(FIGURE, dpi=100)
    print(f"wrote {FIGURE} ({FIGURE.stat().st_size // 1024} kB)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
