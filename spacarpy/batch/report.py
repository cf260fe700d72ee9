"""Write the outcome of a batch: a readable table, JUnit XML (for CI systems), or JSON.

The outcomes are :class:`spacarpy.batch.runner.DeckOutcome` records; :func:`write_report`
picks the format from the file name (``.xml`` JUnit, ``.json`` JSON, anything else the table).
"""
from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from collections import Counter
from pathlib import Path

__all__ = ["check_report_paths", "format_table", "summary_line", "to_json", "to_junit",
           "write_report"]

_ORDER = ("failed", "changed", "new", "pass", "not run")


def summary_line(outcomes) -> str:
    """``30 decks: 28 pass, 1 changed, 1 failed, 0 new`` (``, 3 not run`` after an
    interruption)."""
    c = Counter(o.status for o in outcomes)
    not_run = f", {c['not run']} not run (interrupted)" if c["not run"] else ""
    return (f"{len(outcomes)} deck{'s' * (len(outcomes) != 1)}: {c['pass']} pass, "
            f"{c['changed']} changed, {c['failed']} failed, {c['new']} new{not_run}")


def format_table(outcomes) -> str:
    """One line per deck (status, name, seconds, detail), then the summary line."""
    width = max((len(o.name) for o in outcomes), default=4)
    lines = [f"{'STATUS':<8} {'DECK':<{width}} {'TIME':>7}  DETAIL"]
    for o in outcomes:
        detail = o.message.splitlines()
        lines.append(f"{o.status.upper():<8} {o.name:<{width}} {o.seconds:6.1f}s  "
                     f"{detail[0] if detail else ''}")
        lines += [f"{'':<8} {'':<{width}} {'':>7}  {d}" for d in detail[1:]]
    lines.append(summary_line(outcomes))
    return "\n".join(lines) + "\n"


def to_json(outcomes) -> str:
    """A JSON document: ``{"summary": {...}, "decks": [{name, status, seconds, message,
    datasets: [{path, index, value, baseline, rel_diff, n_bad}]}]}``."""
    def num(v):
        return v if v == v and abs(v) != float("inf") else str(v)

    c = Counter(o.status for o in outcomes)
    doc = {"summary": {s: c[s] for s in _ORDER} | {"total": len(outcomes)},
           "decks": [{"name": o.name, "status": o.status, "seconds": round(o.seconds, 3),
                      "message": o.message,
                      "datasets": [{"path": d.path, "index": list(d.index) if d.index else None,
                                    "value": num(d.value), "baseline": num(d.baseline),
                                    "rel_diff": num(d.rel_diff), "n_bad": d.n_bad}
                                   for d in o.diffs]}
                     for o in outcomes]}
    return json.dumps(doc, indent=2) + "\n"


def to_junit(outcomes, suite: str = "spacarpy batch") -> str:
    """JUnit XML: one ``testcase`` per deck; changed decks are ``failure``s, failed decks
    ``error``s, new decks ``skipped`` (no baseline), as are the decks an interrupted batch
    did not run."""
    c = Counter(o.status for o in outcomes)
    root = ET.Element("testsuites")
    ts = ET.SubElement(root, "testsuite", name=suite, tests=str(len(outcomes)),
                       failures=str(c["changed"]), errors=str(c["failed"]),
                       skipped=str(c["new"] + c["not run"]),
                       time=f"{sum(o.seconds for o in outcomes):.3f}")
    for o in outcomes:
        tc = ET.SubElement(ts, "testcase", classname="spacarpy.batch", name=o.name,
                           time=f"{o.seconds:.3f}")
        first = o.message.splitlines()[0] if o.message else ""
        if o.status == "changed":
            el = ET.SubElement(tc, "failure", message=first, type="changed")
            el.text = "\n".join(d.message for d in o.diffs)
        elif o.status == "failed":
            el = ET.SubElement(tc, "error", message=first, type="failed")
            el.text = o.message
        elif o.status == "new":
            ET.SubElement(tc, "skipped", message="no baseline")
        elif o.status == "not run":
            ET.SubElement(tc, "skipped", message="not run: the batch was interrupted")
    ET.indent(root)
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, "unicode") + "\n"


def check_report_paths(paths, inputs=()) -> list[Path]:
    """Refuse, before any deck runs, a ``--report`` file that cannot be written (a
    directory, a missing or read-only directory, a deck): :func:`spacarpy.outputs.
    check_output_path`. Raises :class:`spacarpy.outputs.OutputError` (exit 2)."""
    from spacarpy.outputs import check_output_path
    return [check_output_path(p, "--report", inputs=inputs) for p in paths]


def write_report(outcomes, path) -> Path:
    """Write the report to ``path`` atomically; the suffix picks the format (.xml, .json,
    else text). Its directory must exist (:func:`check_report_paths`)."""
    from spacarpy.outputs import write_atomically
    path = Path(path)
    suffix = path.suffix.lower()
    text = (to_junit(outcomes) if suffix == ".xml" else
            to_json(outcomes) if suffix == ".json" else format_table(outcomes))
    return write_atomically(path, text)
