"""Convergence of a cantilever's frequencies with lumped and consistent rotary inertia.

The table of docs/linearized.md ("Rotary inertia: lumped or consistent") is this module's
output: ``python tests/rotary_convergence.py`` prints it; tests/test_rotary_inertia.py
checks the convergence orders and that the page shows these numbers.

Two cantilevers of length L = 1, clamped at x = 0, meshed with n equal BEAMs:

- in-plane bending (DYNE e 5 6 only): EIz = rhoA = 1, rhoIz = 1e-3 (slenderness L/r = 31.6),
  against the Rayleigh beam (Euler-Bernoulli with rotary inertia), whose frequency equation
  is solved here to round-off;
- torsion (DYNE e 2 only): GJ = 1, rho Ip = 0.5, against f_k = (2k - 1)/(4L) sqrt(GJ/rho Ip).
"""
from __future__ import annotations

import numpy as np
from scipy.optimize import brentq

from spacarpy.deck import job_from_text
from spacarpy.solvers.linear.eigen import eigenmodes
from spacarpy.solvers.linear.linearize import MassAssembler, linearize
from spacarpy.solvers.statics.equilibrium import StaticProblem

MESHES = (1, 2, 4, 8, 16, 32, 64)
EI, RHO_A, RHO_I = 1.0, 1.0, 1e-3
GJ, RHO_IP = 1.0, 0.5


def cantilever_deck(n: int, which: str, rotary: str) -> str:
    """n BEAMs along x; ``which`` = "bending" (modes 5 6 flexible) or "torsion" (mode 2)."""
    lines = [f"X {2 * i + 1} {i / n!r} 0 0" for i in range(n + 1)]
    dyne = "5 6" if which == "bending" else "2"
    for e in range(1, n + 1):
        lines += [f"BEAM {e} {2 * e - 1} {2 * e} {2 * e + 1} {2 * e + 2} 0 1 0",
                  f"DYNE {e} {dyne}"]
    lines += ["FIX 1", "FIX 2", "END", "HALT",
              f"ESTIFF 1:{n} 1e6 {GJ!r} 1 {EI!r}",
              f"EM 1:{n} {RHO_A!r} {RHO_IP!r} {RHO_I!r} {RHO_I!r} 0",
              f"ROTARYINERTIA {rotary}", "MODE eigen", "END", "END"]
    return "\n".join(lines) + "\n"


def frequencies(n: int, which: str, rotary: str, count: int = 2) -> np.ndarray:
    """The lowest ``count`` frequencies (Hz) of the mesh (NaN where it has fewer)."""
    model, settings = job_from_text(cantilever_deck(n, which, rotary), f"<{which} {n}>")
    prob = StaticProblem(model)
    num = prob.num
    lin = linearize(prob, num.x0, np.zeros(num.n_constraint), prob.loads.unloaded(),
                    mass=MassAssembler(model, num, rotary=settings.rotary_inertia))
    f = eigenmodes(lin, num, prob.free, n_modes=count).frequency
    return np.concatenate([f, np.full(count - f.size, np.nan)])


def _rayleigh_determinant(omega: float, rho_i: float) -> float:
    """det of the clamped-free boundary conditions of EI w'''' + rhoI w2 w'' - rhoA w2 w = 0
    (L = 1), w = A cosh(a x) + B sinh(a x) + C cos(b x) + D sin(b x); free end: w'' = 0 and
    the shear EI w''' + rhoI w2 w' = 0."""
    w2 = omega * omega
    root = np.sqrt((rho_i * w2) ** 2 + 4.0 * EI * RHO_A * w2)
    a = np.sqrt((-rho_i * w2 + root) / (2.0 * EI))
    b = np.sqrt((rho_i * w2 + root) / (2.0 * EI))
    ch, sh, c, s = np.cosh(a), np.sinh(a), np.cos(b), np.sin(b)
    k = rho_i * w2 / EI
    m = np.array([
        [1.0, 0.0, 1.0, 0.0],
        [0.0, a, 0.0, b],
        [a * a * ch, a * a * sh, -b * b * c, -b * b * s],
        [a**3 * sh + k * a * sh, a**3 * ch + k * a * ch, b**3 * s - k * b * s,
         -b**3 * c + k * b * c]])
    return float(np.linalg.det(m) / ch**2)


def rayleigh_cantilever(count: int = 2, rho_i: float = RHO_I) -> np.ndarray:
    """The lowest ``count`` bending frequencies (Hz) of the Rayleigh cantilever."""
    grid = np.linspace(0.05, 80.0, 4000)
    val = np.array([_rayleigh_determinant(w, rho_i) for w in grid])
    hits = np.flatnonzero(np.sign(val[:-1]) != np.sign(val[1:]))[:count]
    return np.array([brentq(_rayleigh_determinant, grid[i], grid[i + 1], args=(rho_i,),
                            xtol=1e-14, rtol=1e-15) for i in hits]) / (2 * np.pi)


def torsion_cantilever(count: int = 2) -> np.ndarray:
    k = np.arange(1, count + 1)
    return (2 * k - 1) / 4.0 * np.sqrt(GJ / RHO_IP)


def relative_errors(meshes=MESHES) -> dict:
    """{(which, rotary): (len(meshes), 2) relative errors f/f_exact - 1 of f1 and f2}."""
    exact = {"bending": rayleigh_cantilever(), "torsion": torsion_cantilever()}
    return {(which, rotary): np.array([frequencies(n, which, rotary) / exact[which] - 1
                                       for n in meshes])
            for which in ("bending", "torsion") for rotary in ("lumped", "consistent")}


def _cell(v: float) -> str:
    return "—" if np.isnan(v) else f"{v:+.2e}"


def markdown_table(errors: dict | None = None, meshes=MESHES) -> str:
    """The page's table: one row per mesh, the relative errors of f1 and f2 of bending and
    torsion with each option."""
    errors = relative_errors(meshes) if errors is None else errors
    head = ["elements"]
    cols = []
    for which in ("bending", "torsion"):
        for k in (0, 1):
            for rotary in ("lumped", "consistent"):
                head.append(f"{which} f{k + 1} {rotary}")
                cols.append(errors[which, rotary][:, k])
    rows = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for i, n in enumerate(meshes):
        rows.append("| " + " | ".join([str(n)] + [_cell(c[i]) for c in cols]) + " |")
    return "\n".join(rows)


if __name__ == "__main__":
    print("exact: bending (Rayleigh) f1, f2 =", rayleigh_cantilever(),
          "Hz; torsion f1, f2 =", torsion_cantilever(), "Hz")
    print(markdown_table())
