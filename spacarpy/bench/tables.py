"""The tables of ``spacarpy bench``: columns per case, as text and as Markdown, the
machine's summary line, and the generated part of docs/performance.md."""
from __future__ import annotations

import datetime
import platform

import numpy as np

from spacarpy.bench.decks import DECK_CASES, PEERS, TITLES

#: the peers' names in the column headers (``--peer``; True means Exudyn, as before)
PEER_NAMES = {"exudyn": "Exudyn", "opensees": "OpenSees"}


def peer_name(peer) -> str:
    """The column-header name of ``peer`` (a ``--peer`` choice, or True for Exudyn)."""
    return PEER_NAMES.get(peer, "Exudyn") if isinstance(peer, str) else "Exudyn"


def _columns(case: str, peer):
    """(header, width, format function) per column; ``peer``: False, True (Exudyn) or a
    ``--peer`` choice, whose name heads the peer's columns."""
    name = peer_name(peer)
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
    cols = [("grid", 9, lambda r: r.get("grid") or "-")] if case == "lattice" else []
    cols += [("elements", 9, f("n", "d")), ("unknowns", 9, f("unknowns", "d")),
            ("setup s", 8, f("setup", ".2f")), ("solve min s", 11, f("total", ".3f")),
            ("median s", 9, f("median", ".3f"))]
    if case in ("cantilever", "bend", "lattice"):
        cols += [("iters", 6, f("iterations", "d")), ("LU", 5, f("factorizations", "d")),
                 ("reused", 6, f("reuses", "d")),
                 ("ms/iter", 8, f("per_iter", ".2f", 1e3)),
                 ("kernels", 8, f("kernels", ".2f", 1e3)),
                 ("assembly", 9, f("assembly", ".2f", 1e3)),
                 ("solve", 7, f("solve", ".2f", 1e3)), ("other", 7, f("other", ".2f", 1e3)),
                 ({"lattice": "top u_x (m)"}.get(case, "tip y (m)"), 11,
                  f("result", ".4f" if case == "bend" else ".6e" if case == "lattice"
                    else ".6f"))]
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
    if case in ("cantilever", "bend", "lattice"):
        cols += [("est. MB", 8, f("estimate_mb", ".0f"))]
    if case == "cantilever" or (case == "lattice" and peer):
        cols += [("whole s", 8, f("whole", ".3f"))]
    if peer:
        unit = {"eigen": "f1 (Hz)", "bend": "tip y (m)", "lattice": "top u_x (m)"}.get(
            case, "tip u_y (m)")
        cols += [(f"{name} s", 9, _peer_seconds("total")),
                 (f"{name} its", 10, lambda r: _peer_get(r, "iterations", "d")),
                 (f"{name} {unit}", 16, lambda r: _peer_get(
                     r, "result", ".4f" if case in ("eigen", "bend")
                     else ".6e" if case == "lattice" else ".6f")),
                 ("ratio", 6, _ratio)]
        if case == "lattice":
            cols += [("rel. diff", 9, _relative_difference)]
        if case == "cantilever" or (case == "lattice" and name == "Exudyn"):
            cols += [("Exudyn whole s", 14, _peer_seconds("whole")),
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


def _stopped(row) -> float | None:
    """The time limit at which the peer's own solve was stopped (a lower bound of its
    time), or None."""
    p = row.get("peer") or {}
    return p.get("limit") if p.get("stopped") else None


def _peer_seconds(key: str):
    """The column of the peer's ``key`` time (``total``: the solve, ``whole``: the process);
    ">T" where its solve was stopped at T seconds."""
    def get(row):
        limit = _stopped(row)
        if not limit:
            return _peer_get(row, key, ".3f")
        return f">{limit:.0f}" if limit >= 1 else f">{limit:.2g}"      # not ">0"
    return get


def _whole_ratio(row):
    """spacarpy's whole-process time over the peer's ("<x" against a stopped peer)."""
    p = row.get("peer") or {}
    limit = _stopped(row)
    if row.get("whole") is not None and limit:
        return f"<{row['whole'] / limit:.3f}"
    if row.get("whole") is None or not p.get("whole"):
        return "-"
    return f"{row['whole'] / p['whole']:.2f}"


def _ratio(row):
    """spacarpy's solve time over the peer's ("<x" against a stopped peer)."""
    p = row.get("peer")
    limit = _stopped(row)
    if limit and row.get("total") is not None:
        return f"<{row['total'] / limit:.3f}"
    if not p or not p.get("ok") or not p.get("total") or row.get("total") is None:
        return "-"
    return f"{row['total'] / p['total']:.2f}"


def _relative_difference(row):
    """|spacarpy's answer / the peer's - 1|."""
    p = row.get("peer") or {}
    ours, theirs = row.get("result"), p.get("result")
    if not p.get("ok") or ours is None or theirs is None or not np.isfinite(theirs) \
            or theirs == 0:
        return "-"
    return f"{abs(ours / theirs - 1):.1e}"


def _text_table(case: str, rows: list[dict], peer) -> list[str]:
    cols = _columns(case, peer)
    header = " ".join(f"{h:>{w}}" for h, w, _ in cols)
    lines = [header, "-" * len(header)]
    for r in rows:
        if "error" in r:
            lines.append(f"{r.get('command') or r['n']:>9}  failed: {r['error']}")
            continue
        lines.append(" ".join(f"{get(r):>{w}}" for _, w, get in cols))
    return lines


def _markdown_table(case: str, rows: list[dict], peer) -> list[str]:
    cols = _columns(case, peer)
    lines = ["| " + " | ".join(h for h, _, _ in cols) + " |",
             "|" + "|".join("---:" for _ in cols) + "|"]
    for r in rows:
        if "error" in r:
            lines.append(f"| {r.get('command') or r['n']} | failed: {r['error']} |"
                         + " |" * (len(cols) - 2))
            continue
        lines.append("| " + " | ".join(get(r) for _, _, get in cols) + " |")
    notes = [f"- {r['n']} elements, {peer_name(peer)}: {r['peer']['reason']}" for r in rows
             if r.get("peer") and r["peer"].get("reason")
             and (not r["peer"].get("ok") or r["peer"].get("stopped"))]
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
    from spacarpy.solvers.linalg import pardiso
    threads = pardiso.threads()
    solver = ("no PARDISO" if threads is None
              else f"PARDISO {threads} thread{'' if threads == 1 else 's'}")
    return (f"spacarpy {__version__}, Python {platform.python_version()}, numpy "
            f"{numpy.__version__}, scipy {scipy.__version__}; {cpu}, {os.cpu_count()} cores, "
            f"{solver}")



def _title(case: str, transient_steps: int, spinup_t_end: float = 30.0) -> str:
    return TITLES[case].format(steps=transient_steps, t_end=spinup_t_end)


#: The generated part of docs/performance.md lies between these lines; the rest of the page
#: is written by hand and kept.
MARKDOWN_BEGIN = "<!-- spacarpy bench: generated tables begin -->"
MARKDOWN_END = "<!-- spacarpy bench: generated tables end -->"


def write_markdown(path: str, results: dict, peer, n_steps: int, transient_steps: int,
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
        case_peer = peer if peer and case in PEERS.get(peer, PEERS["exudyn"]) else False
        parts.append("\n".join(_markdown_table(case, rows, case_peer)) + "\n")
    block = "\n".join([MARKDOWN_BEGIN, *parts, MARKDOWN_END])
    page = Path(path)
    old = page.read_text() if page.exists() else ""
    if MARKDOWN_BEGIN in old and MARKDOWN_END in old:
        head, rest = old.split(MARKDOWN_BEGIN, 1)
        text = head + block + rest.split(MARKDOWN_END, 1)[1]
    else:
        text = "# Performance\n\n" + block + "\n"
    from spacarpy.outputs import atomic_output
    with atomic_output(page) as staged:      # whole or not at all (a full disk)
        staged.write_text(text)
