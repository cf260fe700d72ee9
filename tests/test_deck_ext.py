"""spacarpy deck extensions: SET and {expressions}, ranges, INCLUDE, the BEAMS/BEAMARC
generators, the Python API (ModelBuilder), Model -> deck round trips, cross-sections."""
from __future__ import annotations

import inspect
import math
from pathlib import Path

import numpy as np
import pytest

from spacarpy.bench.cases import BEND, bend_deck
from spacarpy.deck import (
    ModelBuilder,
    build_job,
    build_model,
    cross_sections,
    load,
    load_deck,
    model_to_deck,
    parse_deck,
)
from spacarpy.deck.generators import arc_points, line_points
from spacarpy.errors import DeckError
from spacarpy.expressions import ExpressionError, evaluate
from spacarpy.model import FLEXIBLE
from spacarpy.solvers.statics.static import solve_static

ROOT = Path(__file__).resolve().parents[1]
CORPUS = ROOT.parent / "shared" / "spacar-decks"
BASE = "X 1 0 0 0\nX 3 1 0 0\nBEAM 1 1 2 3 4\n"


def build(text: str, **kw):
    return build_model(parse_deck(text, "t.dat", **kw), text=text, path="t.dat")


def build_both(text: str, **kw):
    """The job (model and settings) of deck text."""
    return build_job(parse_deck(text, "t.dat", **kw), text=text, path="t.dat")


def errors(text: str, **kw) -> list[tuple[int, int, str]]:
    with pytest.raises(DeckError) as info:
        build(text, **kw)
    return [(loc.line, loc.column, msg) if loc else (0, 0, msg)
            for loc, msg, _ in info.value.items]


def assert_jobs_equal(a, b, atol=0.0):
    """Two jobs: their models (:func:`assert_models_equal`) and their analysis settings."""
    assert_models_equal(a.model, b.model, atol=atol)
    sa, sb = a.settings, b.settings
    ia, ib = sa.iterstep, sb.iterstep
    assert (ia.max_iter, ia.n_steps, ia.tol, ia.n_init, ia.extra) == \
        (ib.max_iter, ib.n_steps, ib.tol, ib.n_init, ib.extra)
    assert (sa.analysis, sa.deformations, sa.bifurcation) == \
        (sb.analysis, sb.deformations, sb.bifurcation)
    assert (sa.linearized, sa.transient) == (sb.linearized, sb.transient)


def assert_models_equal(a, b, atol=0.0):
    """Every array and field of two models (not the deck text, path and locations)."""
    np.testing.assert_array_equal(a.position_ids, b.position_ids)
    np.testing.assert_allclose(a.position_x0, b.position_x0, rtol=0, atol=atol)
    np.testing.assert_array_equal(a.orientation_ids, b.orientation_ids)
    for name in ("ids", "nodes", "vector", "def_class", "stiffness", "has_stiffness",
                 "mass"):
        np.testing.assert_array_equal(getattr(a.elements["BEAM"], name),
                                      getattr(b.elements["BEAM"], name), name)
    assert [(f.node, f.coords) for f in a.fixes] == [(f.node, f.coords) for f in b.fixes]
    assert [(ld.node, ld.kind, ld.value) for ld in a.loads] == \
        [(ld.node, ld.kind, ld.value) for ld in b.loads]
    assert [(m.node, m.values) for m in a.nodal_masses] == \
        [(m.node, m.values) for m in b.nodal_masses]


# ------------------------------------------------------------------ SET and expressions

def test_set_parameters_and_expressions_in_fields():
    text = ("SET R 100\nSET half {R/2}\nX 1 0 0 0\nX 3 {R*sin(pi/4)} {-2^2} {R*(1-cos(pi/4))}\n"
            "X 5 {2^3^2} {2**-1} {atan2(1, 1)*4}\nX 7 {half} { 1.5D1 } {sqrt(16)+abs(-1)}\n")
    sts = parse_deck(text)
    assert [s.keyword for s in sts] == ["SET", "SET", "X", "X", "X", "X"]
    assert sts[0].fields == ("R", 100.0) and sts[1].fields == ("half", 50.0)
    assert sts[3].fields == (3, 100 * math.sin(math.pi / 4), -4.0,
                             100 * (1 - math.cos(math.pi / 4)))
    assert sts[4].fields == (5, 512.0, 0.5, math.pi)
    assert sts[5].fields == (7, 50.0, 15.0, 5.0)


def test_expression_in_a_whole_number_field():
    sts = parse_deck("SET n 4\nDYNE {n} {0.1*30} {n-1}\n")
    assert sts[1].fields == (4, 3, 3) and all(isinstance(v, int) for v in sts[1].fields)
    assert errors(BASE + "FIX 1 {1.5}\n") == [
        (4, 7, "FIX: the coordinate number must be a whole number, but {1.5} = 1.5")]
    assert errors(BASE + "FIX {1-1}\n") == [
        (4, 5, "FIX: the node number must be a positive whole number, found {1-1} = 0")]


@pytest.mark.parametrize("field, column, message", [
    ("{1/0}", 8, "division by zero"),
    ("{R2}", 6, "unknown parameter 'R2' (did you mean R?)"),
    ("{r}", 6, "unknown parameter 'r' (did you mean R? names are case-sensitive)"),
    ("{atan2(1)}", 6, "atan2 takes 2 arguments (atan2(y, x), in radians), got 1"),
    ("{sqrt(-1)}", 6, "cannot evaluate sqrt(-1): outside its domain or too large"),
    ("{10^400}", 6, "the result is too large (not a finite number)"),
    ("{2*}", 8, "the expression ends too early: expected a number, a parameter name or '('"),
    ("{(1+2}", 10, "a ')' is missing at the end of the expression"),
    ("{1 2}", 8, "expected an operator (+ - * / ^) before '2' in the expression"),
    ("{sin}", 6, "'sin' is a function: write sin(x)"),
    ("{foo(1)}", 6, "unknown function 'foo' (functions: sqrt, sin, cos, tan, asin, acos, atan, "
                    "atan2, exp, log, log10, abs)"),
    ("{}", 6, "empty expression: write a number or a formula between the braces, e.g. {2*pi/8}"),
    ("{__import__('os')}", 17, "unexpected character ''' in the expression"),
    ("{R", 5, "unterminated expression: '{' needs a matching '}' on the same line (blanks "
              "inside the braces are fine)"),
    ("{R}x", 5, "cannot read '{R}x': an {expression} must be followed by a blank (ranges look "
                "like 1:{n})"),
])
def test_expression_errors_point_into_the_expression(field, column, message):
    assert errors(f"SET R 1\nX 1 {field} 0 0\n") == [(2, column, message)]


def test_no_code_is_ever_evaluated():
    with pytest.raises(ExpressionError):
        evaluate("__import__('os').system('true')")
    with pytest.raises(ExpressionError):
        evaluate("R.real", {"R": 1.0})
    try:                                                     # deep nesting: no crash
        assert evaluate("(" * 3000 + "1" + ")" * 3000) == 1.0
    except ExpressionError as exc:
        assert "nested too deeply" in exc.message


def test_set_rules():
    errs = errors("SET R 10\nSET R 12\nSET pi 3\nSET sin 2\nSET a-b 1\nX 1 {n} 0 0\nSET n 2\n")
    assert errs == [
        (2, 5, "SET: parameter 'R' is already set (line 1); a parameter is set once"),
        (3, 5, "SET: 'pi' is a built-in name and cannot be set"),
        (4, 5, "SET: 'sin' is a built-in name and cannot be set"),
        (5, 5, "SET: 'a-b' is not a valid parameter name (letters, digits and '_', starting "
               "with a letter)"),
        (6, 6, "unknown parameter 'n' (it is SET at line 7, after its use: move the SET up)"),
    ]


def test_overrides_replace_the_set_value():
    text = "SET L 2\nSET n 4\nSET h {L/n}\nX 1 0 0 0\nX 3 {h} 0 0\n"
    sts = parse_deck(text, overrides={"n": "8"})
    assert sts[1].fields == ("n", 8.0) and sts[4].fields[1] == 0.25
    sts = parse_deck(text, overrides={"n": "{2*L}", "L": 3})
    assert sts[4].fields[1] == 0.5
    with pytest.raises(DeckError) as info:
        parse_deck(text, overrides={"N": "1", "n": "1/0"})
    items = [(loc, msg) for loc, msg, _ in info.value.items]
    assert items == [(None, "--set n=1/0: division by zero"),
                     (None, "--set N: the deck has no 'SET N' line to override (its "
                            "parameters: L, n, h)")]
    model = build_model(parse_deck(BASE), text="SET E 1\n" + BASE, path="t.dat",
                        overrides={"E": "2"})
    assert model.elements["BEAM"].n_elem == 1


def test_load_deck_with_overrides(tmp_path):
    deck = tmp_path / "bend.dat"
    deck.write_text(bend_deck(8))
    model = load_deck(deck, overrides={"n": 3, "R": "50"})
    assert model.elements["BEAM"].n_elem == 3
    np.testing.assert_allclose(model.position_x0[-1], [50 * math.sin(math.pi / 4), 0,
                                                        50 * (1 - math.cos(math.pi / 4))])


# ------------------------------------------------------------------ ranges

def test_ranges_expand_records_and_lists():
    sts = parse_deck("SET n 3\nDYNE 1:{n} 1:3 6\nRLSE 2:2:6 2\nFIX 7 1:3\nESTIFF 4:5 1 2 3 4\n")
    dyne = [s.fields for s in sts if s.keyword == "DYNE"]
    assert dyne == [(1, 1, 2, 3, 6), (2, 1, 2, 3, 6), (3, 1, 2, 3, 6)]
    assert [s.fields[0] for s in sts if s.keyword == "RLSE"] == [2, 4, 6]
    assert [s.fields for s in sts if s.keyword == "FIX"] == [(7, 1, 2, 3)]
    estiff = [s for s in sts if s.keyword == "ESTIFF"]
    assert [s.fields for s in estiff] == [(4, 1.0, 2.0, 3.0, 4.0), (5, 1.0, 2.0, 3.0, 4.0)]
    assert len(estiff[0].field_locs) == 5 and estiff[0].field_locs[0].column == 8


@pytest.mark.parametrize("line, column, message", [
    ("DYNE 3:1 1", 6, "DYNE: the range '3:1' is empty: it must count upwards (first 3 > last 1)"),
    ("DYNE 1:0:3 1", 6, "DYNE: the step of the range '1:0:3' must be at least 1 "
                        "(first:step:last)"),
    ("DYNE 0:3 1", 6, "DYNE: the range '0:3' must start at 1 or more"),
    ("DYNE 1:2000001 1", 6, "DYNE: the range '1:2000001' has 2000001 numbers; at most 1000000 "
                            "are allowed"),
    ("X 1:3 0 0 0", 3, "X: the node number cannot be a range ('1:3'); ranges are allowed for "
                       "the element number of DYNE, RLSE, ESTIFF and EM and in lists of numbers "
                       "(FIX, DYNE and RLSE modes, BEAMPROPS, ...)"),
    ("DYNE 1:{1.5} 1", 8, "DYNE: the range '1:{1.5}' needs whole numbers, but {1.5} = 1.5"),
    ("DYNE 1: 1", 6, "cannot read the range '1:': ranges look like 1:48 or 1:2:47 "
                     "(first:step:last)"),
])
def test_range_errors(line, column, message):
    with pytest.raises(DeckError) as info:
        parse_deck(line + "\n")
    assert [(loc.line, loc.column, msg) for loc, msg, _ in info.value.items] == \
        [(1, column, message)]


# ------------------------------------------------------------------ INCLUDE

def test_include_relative_to_the_including_file_and_shares_parameters(tmp_path):
    (tmp_path / "parts").mkdir()
    (tmp_path / "parts" / "nodes.dat").write_text("SET L 2\nX 1 0 0 0\nX 3 {L} 0 0\n"
                                                  'INCLUDE "data.dat"\n')
    (tmp_path / "parts" / "data.dat").write_text("FIX 1\nFIX 2\nEND\nHALT\n")
    main = tmp_path / "main.dat"
    main.write_text('INCLUDE "parts/nodes.dat"\nBEAM 1 1 2 3 4\nDYNE 1 1:6\n'
                    "ESTIFF 1 {L} 1 1 1\nEND\nEND\n")
    model = load_deck(main)
    np.testing.assert_array_equal(model.position_x0, [[0, 0, 0], [2, 0, 0]])
    assert model.elements["BEAM"].stiffness[0, 0] == 2.0
    sts = parse_deck(main.read_text(), str(main))
    modules = {(s.keyword, s.fields[:1]): s.module for s in sts}
    assert modules[("FIX", (1,))] == 0 and modules[("ESTIFF", (1,))] == 1
    assert sts[1].loc.file == str(tmp_path / "parts" / "nodes.dat")


def test_errors_in_an_included_file_point_into_it(tmp_path):
    (tmp_path / "inc.dat").write_text("X 3 1 0 0\nBEEM 2 3 4 5 6\nX 5 1 0 0\n")
    main = tmp_path / "main.dat"
    main.write_text('X 1 0 0 0\nINCLUDE "inc.dat"\nX 7 {q} 0 0\n')
    with pytest.raises(DeckError) as info:
        load_deck(main)
    items = [(loc.file, loc.line, loc.column, src) for loc, _, src in info.value.items]
    assert items == [(str(tmp_path / "inc.dat"), 2, 1, "BEEM 2 3 4 5 6"),
                     (str(main), 3, 6, "X 7 {q} 0 0")]
    assert f"{tmp_path / 'inc.dat'}:2:1: error: unknown keyword 'BEEM'" in str(info.value)


def test_include_cycles_and_missing_files(tmp_path):
    (tmp_path / "a.dat").write_text('X 1 0 0 0\nINCLUDE "b.dat"\n')
    (tmp_path / "b.dat").write_text('INCLUDE "a.dat"\n')
    with pytest.raises(DeckError) as info:
        load_deck(tmp_path / "a.dat")
    (loc, msg, _), = info.value.items
    assert (loc.file, loc.line, loc.column) == (str(tmp_path / "b.dat"), 1, 9)
    assert msg.startswith("INCLUDE cycle: a.dat -> b.dat -> a.dat")
    (tmp_path / "c.dat").write_text('INCLUDE "c.dat"\nINCLUDE "none.dat"\nINCLUDE 3\n')
    with pytest.raises(DeckError) as info:
        load_deck(tmp_path / "c.dat")
    msgs = [(loc.line, msg) for loc, msg, _ in info.value.items]
    assert msgs[0] == (1, "INCLUDE cycle: c.dat -> c.dat (a file may not include itself, "
                          "directly or indirectly)")
    assert msgs[1][0] == 2 and msgs[1][1].startswith("INCLUDE: cannot read 'none.dat'")
    assert msgs[1][1].endswith("no such file")
    assert msgs[2] == (3, "INCLUDE: expected the file name (in double quotes) (a word), "
                          "found '3'")


# ------------------------------------------------------------------ generators

def test_line_and_arc_points():
    np.testing.assert_allclose(line_points([0, 0, 0], [4, 0, 8], 4),
                               [[1, 0, 2], [2, 0, 4], [3, 0, 6]])
    pts = arc_points([0, 0, 0], [1, 0, 1], [0, 0, 1], 6)        # quarter circle, radius 1
    np.testing.assert_allclose(np.linalg.norm(pts - [0, 0, 1], axis=1), 1.0, rtol=1e-15)
    angles = np.arctan2(pts[:, 0], 1 - pts[:, 2])
    np.testing.assert_allclose(angles, np.arange(1, 6) * np.pi / 12, rtol=1e-14)


def test_beams_reproduces_the_spacar_light_subdivision_of_a_real_deck():
    """spatools_cantilever.dat is SPACAR Light's output for one beam split in four; the
    generator, with the same numbering rule, gives exactly the same model."""
    path = CORPUS / "spatools_cantilever.dat"
    if not path.is_file():
        pytest.skip(f"{path} is absent")
    text = ("X 1 0 0 0\nX 3 1 0 0\nBEAMS 1 1 2 3 4 4 0 0 1\nDYNE 1:4 1:6\nFIX 1\nFIX 2\n"
            "END\nHALT\nESTIFF 1:4 525000000 63082.154762 109375 109375 0.000729 0.000729\n"
            "EM 1:4 19.5 0.008125 0.004063 0.004063 0\n"
            "DELXF 3 -10000000000.000000 0 0\nXF 3 0 10 0\nITERSTEP 10 9 0.0000005 1 3 9\n"
            "END\nEND\n")
    assert_jobs_equal(build_both(text), load(path))


def test_generator_numbering_rule_and_order():
    text = ("X 1 0 0 0\nX 3 3 0 0\nX 41 3 3 0\n"
            "BEAMS 10 1 2 3 4 3 0 0 1\n"            # N = 42: nodes 43/44, 45/46
            "BEAMS 20 3 4 41 42 2 0 0 1\n"          # continues: 47/48
            "BEAM 30 41 42 1 2 0 0 1\n"
            "FIX 1\nFIX 2\nFIX 45 3\n")
    model = build(text)
    np.testing.assert_array_equal(model.position_ids, [1, 3, 41, 43, 45, 47])
    np.testing.assert_allclose(model.position_x0[3:], [[1, 0, 0], [2, 0, 0], [3, 1.5, 0]])
    np.testing.assert_array_equal(model.orientation_ids, [2, 4, 42, 44, 46, 48])
    np.testing.assert_array_equal(model.elements["BEAM"].ids, [10, 11, 12, 20, 21, 30])
    np.testing.assert_array_equal(model.elements["BEAM"].nodes[:5],
                                  [[1, 2, 43, 44], [43, 44, 45, 46], [45, 46, 3, 4],
                                   [3, 4, 47, 48], [47, 48, 41, 42]])
    np.testing.assert_array_equal(model.elements["BEAM"].vector[:5], [[0, 0, 1]] * 5)
    assert [f.node for f in model.fixes] == [1, 2, 45]       # generated nodes are referable


def explicit_bend(n: int, numbering: str) -> str:
    """The Table 2 bend written out line by line from the arc formula.

    numbering "generator": the generator's rule (ends 1/2 and 3/4, intermediate nodes 5, 6, ...,
    tip X line last); "paper": the numbering of the old shipped decks (node 2i+1/2i+2)."""
    b = BEND
    th = np.linspace(0.0, np.pi / 4, n + 1)
    pts = np.stack([b["R"] * np.sin(th), 0 * th, b["R"] * (1 - np.cos(th))], axis=1)
    if numbering == "generator":
        pos = [1] + [4 + 2 * k - 1 for k in range(1, n)] + [3]
    else:
        pos = [2 * i + 1 for i in range(n + 1)]
    rot = [p + 1 for p in pos]
    lines = ["DEFORMATIONS modified"]
    lines += [f"X {p} {x!r} {y!r} {z!r}" for p, (x, y, z) in zip(pos, pts.tolist())]
    lines += [f"BEAM {e + 1} {pos[e]} {rot[e]} {pos[e + 1]} {rot[e + 1]} 0 1 0" for e in range(n)]
    lines += [f"DYNE {e + 1} 1 2 3 4 5 6" for e in range(n)] + ["FIX 1", "FIX 2", "END", "HALT"]
    c = b["EI"] / b["kGA"]
    lines += [f"ESTIFF {e + 1} {b['EA']!r} {b['EI']!r} {b['EI']!r} {b['EI']!r} {c!r} {c!r}"
              for e in range(n)]
    lines += [f"DELXF {pos[-1]} 0 600 0", "ITERSTEP 20 10 1e-9", "END", "END"]
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("n", [8, 48])
def test_table2_generator_deck_equals_the_explicit_arc(n):
    generated = build_both(bend_deck(n))
    explicit = build_both(explicit_bend(n, "generator"))
    assert_jobs_equal(generated, explicit, atol=1e-12)
    np.testing.assert_array_equal(generated.model.elements["BEAM"].def_class, FLEXIBLE)
    assert (ROOT / "decks" / f"table2_bend_{n}el_modified.dat").read_text() == bend_deck(n)


def tip_position(job, tip: int) -> np.ndarray:
    model = job.model
    res = solve_static(model, job.settings)
    row = list(model.position_ids).index(tip)
    return res.steps[-1].x[res.problem.num.pos_idx[row]]


def test_table2_generator_deck_gives_the_results_of_the_old_explicit_deck():
    new = tip_position(build_both(bend_deck(8)), tip=3)
    old = tip_position(build_both(explicit_bend(8, "paper")), tip=17)
    np.testing.assert_allclose(new, old, rtol=1e-9)
    assert tuple(np.round(new, 2)) == (46.94, 53.64, 15.64)      # Table 2, 8 elements


@pytest.mark.parametrize("line, column, message", [
    ("BEAMS 5 1 2 9 10 4", 13, "BEAMS: position node 9 (at q) has no X line"),
    ("BEAMS 5 1 2 1 10 4", 13, "BEAMS: p and q are the same node (1)"),
    ("BEAMS 5 1 2 7 10 4", 1, "BEAMS: nodes 1 and 7 are at the same position"),
    ("BEAMS 5 1 2 3 10 4 1 0 0", 20, "BEAMS: the orientation vector (1, 0, 0) is parallel to "
                                     "the axis of element 5; give a local y-axis perpendicular "
                                     "to all the elements"),
    ("BEAMS 5 1 2 3 10 4 0 0 0", 20, "BEAMS: the orientation vector (0, 0, 0) is (nearly) zero"),
    ("BEAMS 5 1 2 3 10 2000000", 18, "BEAMS: at most 1000000 elements per line, got 2000000"),
    ("BEAMARC 5 1 2 3 10 4 0 0 2", 22, "BEAMARC: node 3 is not on the circle through node 1 "
                                       "about the centre: |p - c| = 2, |q - c| = 2.236067977"),
    ("BEAMARC 5 1 2 3 10 4 0.5 0 0", 22, "BEAMARC: the centre lies on the line through p and "
                                         "q, so the plane of the arc is undefined (a half "
                                         "circle); split the arc into two BEAMARC lines"),
    ("BEAMARC 5 1 2 3 10 4 0 0 0", 22, "BEAMARC: the centre coincides with an end node"),
])
def test_generator_errors_without_cascades(line, column, message):
    text = f"X 1 0 0 0\nX 3 1 0 0\nX 7 0 0 0\n{line}\nDYNE 5:8 1:6\nESTIFF 5:8 1 1 1 1\n"
    errs = [e for e in errors(text) if "is not connected" not in e[2]]
    assert errs == [(4, column, message)]


def test_generated_element_numbers_collide_with_explicit_ones():
    errs = errors("X 1 0 0 0\nX 3 2 0 0\nBEAMS 1 1 2 3 4 2\nBEAM 2 1 2 3 4\n")
    assert errs == [(4, 6, "element 2 is defined twice (lines 3 and 4)")]


def test_generated_element_errors_name_the_generator():
    errs = errors("X 1 0 0 0\nX 3 2 0 0\nBEAMS 1 1 3 3 4 2\n")
    assert errs == [(3, 11, "element 1 (made by the BEAMS line): node 3 is a position node (X "
                            "at line 2) and cannot be the orientation node at p")]


# ------------------------------------------------------------------ Python API

def scripted_bend(n: int) -> ModelBuilder:
    R = BEND["R"]
    ei = 1e7 / 12
    return (ModelBuilder("bend")
            .deformations("modified").analysis("static")
            .node(1, 0, 0, 0)
            .beam_arc(1, 1, 2, 3, 4, n, center=(0, 0, R), orientation=(0, 1, 0))
            .node(3, R * math.sin(math.pi / 4), 0, R * (1 - math.cos(math.pi / 4)))
            .flexible(range(1, n + 1))
            .fix(1).fix(2)
            .stiffness(range(1, n + 1), 1e7, ei, ei, ei, ei / 5e6, ei / 5e6)
            .load(3, 0, 600, 0)
            .iterstep(20, 10, 1e-9))


def test_model_builder_gives_the_model_of_the_deck():
    mb = scripted_bend(8)
    assert_jobs_equal(mb.build_job(), load(ROOT / "decks" / "table2_bend_8el_modified.dat"))
    text = mb.to_deck()
    assert "BEAMARC 1 1 2 3 4 8 0 0 100.0 0 1 0" in text
    assert "DYNE 1:8 1 2 3 4 5 6" in text
    assert_jobs_equal(build_both(text), mb.build_job())


def test_model_builder_other_keywords():
    job = (ModelBuilder()
             .node(1, 0, 0, 0).node(3, 1, 0, 0).node(5, 2, 0, 0)
             .beam(1, 1, 2, 3, 4, orientation=(0, 0, 1)).beams(2, 3, 4, 5, 6, 2)
             .flexible(1).flexible([2, 3], modes=(1, 3, 4)).released(2, (2,))
             .fix(1).fix(2).fix(5, 2, 3)
             .stiffness(range(1, 4), 1, 2, 3, 4).mass(1, 2.0, 0.1)
             .nodal_mass(5, 0.5).load(5, 1, 0, 0, initial=True).load(6, 0, 0, 1)
             .iterstep(10, 5, 1e-8, n_init=2).build_job(deformations="basic"))
    model, settings = job
    assert settings.deformations == "basic" and model.elements["BEAM"].n_elem == 3
    assert [(m.node, m.values) for m in model.nodal_masses] == [(5, (0.5,))]
    assert [ld.kind for ld in model.loads] == ["XF", "DELXF"]
    assert settings.iterstep.n_init == 2 and settings.iterstep.extra == (1.0, 3.0)
    assert repr(ModelBuilder().node(1, 0, 0, 0)) == "ModelBuilder(1 deck lines)"


def test_model_builder_errors_point_at_the_script_line():
    # the arguments are checked at the call (the deck's field specs), so the error names
    # the method, the argument and the script line of the call
    mb = ModelBuilder().node(1, 0, 0, 0).node(3, 1, 0, 0)
    here = inspect.currentframe().f_lineno + 2
    with pytest.raises(DeckError) as info:
        mb.beam(1, 1, 2.5, 3, 4)
    ((loc1, msg1, _),) = info.value.items
    assert (loc1.file, loc1.line) == (__file__, here)
    assert msg1 == ("ModelBuilder.beam(): r (orientation node at p) must be a whole number, "
                    "got 2.5")
    with pytest.raises(DeckError) as info:
        mb.node(5, float("nan"), 0, 0)
    ((loc2, msg2, _),) = info.value.items
    assert loc2.line == here + 6 and "must be a finite number, got nan" in msg2
    # what the argument checks cannot see (a node that does not exist) is the deck
    # reader's, located at the call's line and showing the deck line
    here = inspect.currentframe().f_lineno + 1
    mb.beam(1, 1, 2, 7, 4)
    with pytest.raises(DeckError) as info:
        mb.build()
    ((loc, msg, src),) = [it for it in info.value.items if it[2] == "BEAM 1 1 2 7 4"]
    assert (loc.file, loc.line) == (__file__, here)
    assert msg == "element 1: position node 7 (at q) has no X line"


# ------------------------------------------------------------------ round trips

def _round_trip(job, **kw):
    text = model_to_deck(job.model, job.settings, **kw)
    again = build_job(parse_deck(text, "rt.dat"), text=text, path="rt.dat")
    assert_jobs_equal(job, again)
    assert model_to_deck(*again, **kw) == text.replace(job.model.source_path, "rt.dat")
    return text


ROUND_TRIP_DECKS = ["decks/table1_cantilever_2el_basic.dat", "decks/table2_bend_8el_modified.dat",
                    "../shared/spacar-decks/spatools_cantilever.dat",
                    "../shared/spacar-decks/dynastatflex_simple_beam.dat"]


@pytest.mark.parametrize("name", ROUND_TRIP_DECKS)
@pytest.mark.parametrize("compact", [False, True])
def test_deck_model_deck_model_is_identity(name, compact):
    path = ROOT / name
    if not path.is_file():
        pytest.skip(f"{path} is absent")
    text = _round_trip(load(path), compact=compact)
    assert ("DYNE 1:" in text) == compact


def test_round_trip_of_every_model_feature():
    text = ("DEFORMATIONS basic\nMODE eigen\nX 1 0 0 0\nX 3 1 0 0\nX 5 2 0 1e-3\n"
            "BEAM 1 1 2 3 4 0 0 1\nBEAM 2 3 4 5 6\nDYNE 1 1 2 3 4 5 6\nDYNE 2 1 3 4\nRLSE 2 2\n"
            "FIX 1\nFIX 2\nFIX 5 3 2\nFIX 6 1\nEND\nHALT\nESTIFF 1 1e7 1e3 2e3 3e3\n"
            "ESTIFF 2 1e7 1e3 2e3 3e3 1e-4 0.1\nEM 2 2.0 0.1 0.05 0.05 0\nXM 5 0.25\n"
            "XM 4 1e-3 0 0 2e-3 0 3e-3\nXF 5 -1 0 0\nDELXF 4 0 0 0.5\nDELXF 4 0.1 0 0\n"
            "ITERSTEP 10 0 1e-8 1 3 2\nEND\nEND\n")
    job = build_both(text)
    assert np.isnan(job.model.elements["BEAM"].vector[1]).all()
    assert job.settings.iterstep.n_steps == 1
    out = _round_trip(job)
    assert "BEAM 2 3 4 5 6\n" in out and "FIX 1\n" in out and "FIX 5 2 3\n" in out


def test_round_trip_writes_cross_sections():
    text = BASE + "DYNE 1 1\nFIX 1\nFIX 2\nEND\nHALT\nESTIFF 1 1 1 1 1\nEND\nEND\n" \
                  "VISUALIZATION\nBEAMPROPS 1\nCROSSTYPE CIRC\nCROSSDIM 0.01\n"
    sections = cross_sections(parse_deck(text))
    out = model_to_deck(build(text), cross_sections=sections)
    assert out.endswith("VISUALIZATION\nBEAMPROPS 1\nCROSSTYPE CIRC\nCROSSDIM 0.01\n")
    again = cross_sections(parse_deck(out)).get(1)
    assert (again.shape, again.dims) == ("CIRC", (0.01,))


# ------------------------------------------------------------------ cross-sections

def test_cross_sections_of_real_decks():
    path = CORPUS / "mod8_flexure_mode9.dat"
    if not path.is_file():
        pytest.skip(f"{path} is absent")
    sections = cross_sections(parse_deck(path.read_text(encoding="latin-1"), str(path)))
    assert sorted(sections.by_element) == [1, 2, 3, 4]
    assert sections.get(1).dims == (0.046875, 0.0002) and sections.get(4).dims == (0.1875, 0.0006)
    shape, dims = sections.arrays([4, 5, 1])
    assert list(shape) == ["RECT", "", "RECT"]
    np.testing.assert_array_equal(dims[0], [0.1875, 0.0006])
    assert np.isnan(dims[1]).all()
    rect = sections.get(1)
    w, t = rect.dims
    assert rect.area == w * t and rect.second_moments == (w * t**3 / 12, t * w**3 / 12)
    assert rect.extreme_fibre == (w / 2, t / 2)


def test_cross_section_errors_and_warnings(caplog):
    vis = BASE + "DYNE 1 1\nFIX 1\nFIX 2\nEND\nHALT\nESTIFF 1 1 1 1 1\nEND\nEND\nVISUALIZATION\n"
    errs = errors(vis + "BEAMPROPS 1\nCROSSTYPE CIRC\nCROSSDIM 0.1 0.2\nBEAMPROPS 1\n"
                        "CROSSTYPE TUBE\nCROSSDIM 1\nBEAMPROPS 1\nCROSSTYPE RECT\nCROSSDIM 1 -2\n")
    assert errs == [(15, 1, "CROSSDIM: a CIRC cross-section takes 1 value (diameter d), got 2"),
                    (17, 11, "CROSSTYPE: unknown cross-section type 'TUBE'; expected RECT or "
                             "CIRC"),
                    (18, 1, "CROSSDIM without a CROSSTYPE before it (after BEAMPROPS, give "
                            "CROSSTYPE RECT or CIRC first)"),
                    (21, 12, "CROSSDIM: the thickness t (along local z) must be positive, "
                             "got -2")]
    with caplog.at_level("WARNING"):
        build(vis + "CROSSTYPE RECT\nCROSSDIM 1 2\nBEAMPROPS 1 9\nCROSSTYPE CIRC\nCROSSDIM 1\n"
                    "FOO 1 2\n")
    messages = [r.getMessage() for r in caplog.records]
    assert any("CROSSTYPE applies to no element" in m for m in messages)
    assert any("element 9, which is not defined" in m for m in messages)
    assert any("unknown VISUALIZATION keyword 'FOO' is ignored" in m for m in messages)


def test_an_error_repeated_by_a_range_or_generator_is_reported_once():
    text = ("X 1 0 0 0\nX 3 3 0 0\nBEAMS 1 1 2 3 4 3\nDYNE 1:3 1 2\n"
            "ESTIFF 1:3 -1 1 1 1\nFIX 1\nFIX 2\n")
    assert errors(text) == [(5, 12, "ESTIFF 1: EA must not be negative, got -1 (and 2 more like "
                                    "it from this line)")]


# ------------------------------------------------------------------ named fields, settings

def test_statements_have_named_field_access_with_locations():
    st = parse_deck("RHOINF 0.7\nITERSTEP 10 4\n", "t.dat")
    rho, it = st
    assert rho["rho_inf"] == rho.value("rho_inf") == 0.7
    assert (rho.loc_of("rho_inf").line, rho.loc_of("rho_inf").column) == (1, 8)
    assert it.value("tol") is None and it.value("tol", 5e-7) == 5e-7
    assert it.loc_of("tol") == it.loc                  # left out: the keyword's location
    with pytest.raises(KeyError):
        it["tol"]
    with pytest.raises(KeyError):
        it.value("nonsense")


def test_field_specs_carry_the_choices_and_ranges_the_semantics_check():
    from spacarpy.deck.keywords import KEYWORDS
    rho = KEYWORDS["RHOINF"].field("rho_inf")[1]
    assert (rho.min, rho.max, rho.range_text) == (0.0, 1.0, "[0, 1]")
    assert rho.accepts(1.0) and not rho.accepts(1.5)
    assert KEYWORDS["START"].field("start")[1].accepts("STATIC")
    assert KEYWORDS["BIFURCATION"].field("setting")[1].choices == ("off", "warn", "switch")
    [(line, col, msg)] = errors(BASE + "RHOINF 1.5\n")
    assert (line, col) == (4, 8) and msg == "RHOINF: the spectral radius lies in [0, 1], got 1.5"


def test_command_line_choices_make_new_settings():
    job = build_both(BASE + "MODE eigen\nMODES 3\n")
    new = job.settings.override(analysis="8", n_modes=5, modes_each_step=True)
    assert (job.settings.analysis, job.settings.linearized.n_modes) == ("eigen", 3)
    assert (new.analysis, new.linearized.count, new.linearized.modes_each_step) == \
        ("buckling", 5, True)
    with pytest.raises(ValueError, match="unknown analysis 'fancy'"):
        job.settings.override(analysis="fancy")
