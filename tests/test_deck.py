"""Tests of deck parsing (spacarpy.deck.parser) and deck -> Model building
(spacarpy.deck.semantics)."""
from __future__ import annotations

import logging
import math
import re
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from spacarpy.deck import build_job, build_model, load, load_deck, model_from_text, parse_deck
from spacarpy.deck.check import summarize
from spacarpy.errors import DeckError
from spacarpy.model import FLEXIBLE, RELEASED, RIGID, Fix, Load
from spacarpy.settings import IterStep

CORPUS = Path(__file__).resolve().parents[1].parent / "shared" / "spacar-decks"

VALID = """\
# small test deck
X 1 0 0 0
X 3 1 0 0
X 5 2 0 0
BEAM 1 1 2 3 4 0 0 1
BEAM 2 3 4 5 6
DYNE 1 1 2 3 4 5 6
DYNE 2 1 3 4
RLSE 2 2
FIX 1
FIX 2
FIX 5 2
FIX 5 3 2
END
HALT
ESTIFF 1 1e7 1e3 2e3 3e3
ESTIFF 2 1e7 1e3 2e3 3e3 1e-4 2e-4
EM 1 2.0 0.1
XF 5 -1 0 0
DELXF 6 0 0 0.5
ITERSTEP 10 5 1e-8 1 3 2
END
END
VISUALIZATION
BEAMPROPS 1 2
CROSSTYPE RECT
"""


def build(text: str, **kw):
    return build_model(parse_deck(text, "t.dat"), text=text, path="t.dat", **kw)


def settings_of(text: str, **kw):
    """The analysis settings of deck text."""
    return build_job(parse_deck(text, "t.dat"), text=text, path="t.dat", **kw).settings


def deck_error(text: str, **kw) -> DeckError:
    with pytest.raises(DeckError) as info:
        build(text, **kw)
    return info.value


def only_item(err: DeckError):
    assert len(err.items) == 1, str(err)
    loc, msg, _ = err.items[0]
    return loc.line, loc.column, msg


# A kinematically complete one-beam deck to which error tests add lines.
BASE = "X 1 0 0 0\nX 3 1 0 0\nBEAM 1 1 2 3 4\n"


# ------------------------------------------------------------------ valid decks

def test_valid_deck_builds_expected_model():
    m = build(VALID)
    np.testing.assert_array_equal(m.position_ids, [1, 3, 5])
    np.testing.assert_array_equal(m.position_x0, [[0, 0, 0], [1, 0, 0], [2, 0, 0]])
    np.testing.assert_array_equal(m.orientation_ids, [2, 4, 6])
    b = m.elements["BEAM"]
    np.testing.assert_array_equal(b.ids, [1, 2])
    np.testing.assert_array_equal(b.nodes, [[1, 2, 3, 4], [3, 4, 5, 6]])
    np.testing.assert_array_equal(b.vector[0], [0, 0, 1])
    assert np.isnan(b.vector[1]).all()
    np.testing.assert_array_equal(b.def_class, [[FLEXIBLE] * 6,
                                                [FLEXIBLE, RELEASED, FLEXIBLE, FLEXIBLE,
                                                 RIGID, RIGID]])
    np.testing.assert_allclose(b.stiffness, [[1e7, 1e3, 2e3, 3e3, 0, 0],
                                             [1e7, 1e3, 2e3, 3e3, 1e-4, 2e-4]])
    np.testing.assert_array_equal(b.has_stiffness, [True, True])
    np.testing.assert_allclose(b.mass, [[2.0, 0.1, 0, 0, 0], [0, 0, 0, 0, 0]])
    assert [loc.line for loc in b.locs] == [5, 6]
    assert [(f.node, f.coords) for f in m.fixes] == [(1, (1, 2, 3)), (2, (1, 2, 3, 4)),
                                                     (5, (2, 3))]
    assert all(isinstance(f, Fix) for f in m.fixes)
    assert [(ld.node, ld.kind, ld.value) for ld in m.loads] == [
        (5, "XF", (-1.0, 0.0, 0.0)), (6, "DELXF", (0.0, 0.0, 0.5))]
    assert all(isinstance(ld, Load) for ld in m.loads)
    s = settings_of(VALID)
    it = s.static.iterstep
    assert (it.max_iter, it.n_steps, it.tol, it.n_init, it.extra) == (10, 5, 1e-8, 2, (1.0, 3.0))
    assert it.loc.line == 21
    assert s.analysis == "static" and s.deformations == "modified"
    assert m.source_path == "t.dat" and m.source_text == VALID


def test_statements_modules_and_locations():
    sts = parse_deck(VALID, "t.dat")
    kw = [s.keyword for s in sts]
    assert kw[:2] == ["X", "X"] and kw[-3:] == ["VISUALIZATION", "BEAMPROPS", "CROSSTYPE"]
    modules = {s.keyword: s.module for s in sts}
    assert modules["BEAM"] == 0 and modules["ESTIFF"] == 1 and modules["CROSSTYPE"] == -1
    beam = sts[3]
    assert beam.fields == (1, 1, 2, 3, 4, 0.0, 0.0, 1.0)
    assert isinstance(beam.fields[1], int) and isinstance(beam.fields[5], float)
    assert (beam.loc.line, beam.loc.column) == (5, 1)
    assert [fl.column for fl in beam.field_locs] == [6, 8, 10, 12, 14, 16, 18, 20]
    assert beam.source_line == "BEAM 1 1 2 3 4 0 0 1"
    assert sts[-1].fields == ("RECT",)


def test_keywords_case_insensitive():
    m = build(VALID.lower())
    assert m.elements["BEAM"].n_elem == 2 and settings_of(VALID.lower()).iterstep.n_steps == 5
    assert parse_deck("beam 1 1 2 3 4\n")[0].keyword == "BEAM"


def test_comments_both_styles_and_trailing():
    text = ("% header\n# another\n\nX 1 0 0 0   % trailing\nX 3 1 0 0# no space\n"
            "   # indented comment\nBEAM 1 1 2 3 4  # beam\n")
    m = build(text)
    np.testing.assert_array_equal(m.position_ids, [1, 3])
    assert m.elements["BEAM"].n_elem == 1


def test_crlf_tabs_and_missing_final_newline():
    text = VALID.replace("\n", "\r\n").replace(" ", "\t").rstrip("\r\n")
    m = build(text)
    assert m.elements["BEAM"].n_elem == 2
    sts = parse_deck(text)
    assert not sts[0].source_line.endswith("\r")


def test_numbers_in_many_forms_and_int_from_float():
    text = "X 1.000000 1. .5 -1.5E+06\nX 2 1e-3 +2 1.0D-3\nITERSTEP 5.000000 1000.000000\n"
    sts = parse_deck(text)
    assert sts[0].fields == (1, 1.0, 0.5, -1.5e6)
    assert isinstance(sts[0].fields[0], int)
    assert sts[1].fields == (2, 1e-3, 2.0, 1e-3)
    assert sts[2].fields == (5, 1000)


def test_no_end_is_accepted_and_iterstep_defaults():
    m = build(BASE)
    assert m.elements["BEAM"].n_elem == 1
    assert settings_of(BASE).iterstep == IterStep()


def test_iterstep_zero_steps_and_two_fields():
    it = settings_of(BASE + "ITERSTEP 10 0 5e-7 1 3 0\n").iterstep
    assert (it.n_steps, it.n_init) == (1, 1)
    it = settings_of(BASE + "ITERSTEP 5.0 1000.0\n").iterstep
    assert (it.max_iter, it.n_steps, it.tol) == (5, 1000, 5e-7)


@pytest.mark.parametrize("value, expected", [
    ("static", "static"), ("EIGEN", "eigen"), ("10", "static_linearized"),
    ("-10", "static_linearized"), ("3", "transient_linearized"),
    ("0", "check"), ("1", "transient"), ("8", "buckling"), ("4", "eigen"), ("7.0", "eigen"),
    ("-4", "eigen"), ('"buckling"', "buckling")])
def test_mode_extension(value, expected):
    assert settings_of(BASE + f"MODE {value}\n").analysis == expected


def test_mode_invalid_lists_valid_values():
    line, col, msg = only_item(deck_error(BASE + "MODE 6\n"))
    assert (line, col) == (4, 6)
    assert "unknown analysis '6'" in msg and "static" in msg and "10=static" in msg


def test_deformations_extension_and_command_line_overrides():
    s = settings_of(BASE + "DEFORMATIONS basic\nMODE eigen\n")
    assert (s.deformations, s.analysis) == ("basic", "eigen")
    s = settings_of(BASE + "DEFORMATIONS basic\nMODE eigen\n", deformations="modified",
                    analysis="buckling")
    assert (s.deformations, s.analysis) == ("modified", "buckling")
    assert s.override(analysis="7", deformations="basic") == settings_of(
        BASE + "DEFORMATIONS basic\nMODE eigen\n")
    line, col, msg = only_item(deck_error(BASE + "DEFORMATIONS fancy\n"))
    assert (line, col) == (4, 14) and "expected modified or basic" in msg
    err = deck_error(BASE, analysis="nonsense")
    assert err.items[0][0] is None and "unknown analysis" in err.items[0][1]


def test_estiff_seventh_value_warns(caplog):
    text = BASE + "DYNE 1 1\nESTIFF 1 1 2 3 4 5 6 7\n"
    with caplog.at_level(logging.WARNING, logger="spacarpy.deck.semantics"):
        m = build(text)
    np.testing.assert_allclose(m.elements["BEAM"].stiffness[0], [1, 2, 3, 4, 5, 6])
    assert any("7th value" in r.getMessage() for r in caplog.records)


def test_unconnected_position_node_is_an_error_unless_fixed(caplog):
    line, col, msg = only_item(deck_error(BASE + "X 9 5 5 5\n"))
    assert (line, col) == (4, 3)
    assert msg.startswith("position node 9 is not connected to any element: it would float")
    with caplog.at_level(logging.WARNING, logger="spacarpy.deck.semantics"):
        m = build(BASE + "X 9 5 5 5\nFIX 9\n")
    assert 9 in m.position_ids
    assert any("node 9 is not connected" in r.getMessage() for r in caplog.records)


def test_load_deck_reads_file_and_reports_missing(tmp_path):
    p = tmp_path / "d.dat"
    p.write_bytes(("# caf\u00e9\n" + BASE).encode("latin-1"))
    m, s = load(p, analysis="eigen")
    assert s.analysis == "eigen" and m.source_path == str(p)
    assert load_deck(p).source_text == m.source_text
    with pytest.raises(DeckError, match="no such file"):
        load_deck(tmp_path / "missing.dat")


# ------------------------------------------------------------------ the corpus of real decks

def corpus_decks():
    if not CORPUS.is_dir():
        return [pytest.param(None, marks=pytest.mark.skip(
            reason=f"corpus directory {CORPUS} is absent (shared/spacar-decks not checked out)"))]
    return sorted(CORPUS.glob("*.dat"))


@pytest.mark.parametrize("path", corpus_decks(), ids=lambda p: getattr(p, "name", "none"))
def test_corpus_deck_parses(path):
    text = path.read_text(encoding="latin-1")
    sts = parse_deck(text, str(path))
    assert sts and any(s.keyword == "END" for s in sts)


def corpus_path(name: str) -> Path:
    path = CORPUS / name
    if not path.is_file():
        pytest.skip(f"corpus deck {path} is absent")
    return path


def test_corpus_spatools_cantilever_builds():
    m, s = load(corpus_path("spatools_cantilever.dat"))
    np.testing.assert_array_equal(m.position_ids, [1, 3, 5, 7, 9])
    np.testing.assert_array_equal(m.orientation_ids, [2, 4, 6, 8, 10])
    np.testing.assert_array_equal(m.elements["BEAM"].ids, [1, 2, 3, 4])
    assert (m.elements["BEAM"].def_class == FLEXIBLE).all()
    np.testing.assert_allclose(m.elements["BEAM"].stiffness[0],
                               [525e6, 63082.154762, 109375, 109375, 0.000729, 0.000729])
    np.testing.assert_allclose(m.elements["BEAM"].vector, [[0, 0, 1]] * 4)
    assert [(f.node, f.coords) for f in m.fixes] == [(1, (1, 2, 3)), (2, (1, 2, 3, 4))]
    assert [(ld.node, ld.kind) for ld in m.loads] == [(3, "DELXF"), (3, "XF")]
    assert (s.iterstep.max_iter, s.iterstep.n_steps, s.iterstep.n_init) == (10, 9, 9)
    assert s.iterstep.extra == (1.0, 3.0)


def test_corpus_dynastatflex_builds():
    m, s = load(corpus_path("dynastatflex_simple_beam.dat"))
    np.testing.assert_array_equal(m.position_ids, np.arange(1, 50, 2))
    np.testing.assert_array_equal(m.orientation_ids, np.arange(2, 51, 2))
    assert m.elements["BEAM"].n_elem == 24
    # the deck makes only the bending modes 3 and 4 flexible (DYNE e 3 4)
    np.testing.assert_array_equal(m.elements["BEAM"].def_class,
                                  [[RIGID, RIGID, FLEXIBLE, FLEXIBLE, RIGID, RIGID]] * 24)
    assert [(ld.node, ld.kind, ld.value) for ld in m.loads] == [(26, "DELXF", (0.0, 0.0, 0.3))]
    assert (s.iterstep.n_steps, s.iterstep.n_init) == (4, 1)


def test_corpus_slidercrank_builds_with_its_esig_pre_stress():
    """HINGE, BEAM, OUTLEVEL, TIMESTEP and ESIG are supported: ``ESIG 1 1.0`` on the
    released crank hinge is a constant 1 N m stress resultant (a driving torque)."""
    path = corpus_path("oopspa_slidercrank.dat")
    m = load_deck(path)
    assert m.element_prestress == {1: (1.0, 0.0, 0.0)}
    assert m.elements["HINGE"].ids.tolist() == [1, 3]


@pytest.mark.parametrize("path", corpus_decks(), ids=lambda p: getattr(p, "name", "none"))
def test_corpus_deck_statements_are_typed_by_the_real_layouts(path):
    """Every record, also of keywords that are not supported yet, has its fields converted
    by the keyword table: whole numbers are ints, values floats, names str."""
    from spacarpy.deck.keywords import KEYWORDS, VISUALIZATION_KEYWORDS
    for statement in parse_deck(path.read_text(encoding="latin-1"), str(path)):
        kw = statement.keyword
        spec = KEYWORDS.get(kw) or VISUALIZATION_KEYWORDS.get(kw)
        if spec is None or kw == "SET":      # SET, unknown VISUALIZATION lines
            continue
        if spec.data_form is not None and statement.module >= 1:
            spec = spec.data_form
        fields = statement.fields
        assert len(fields) == len(statement.field_locs)
        kinds = [f.kind for f in spec.required] + [f.kind for g in spec.optional for f in g]
        kinds += [spec.variadic.kind] * (len(fields) - len(kinds)) if spec.variadic else []
        for value, kind in zip(fields, kinds):
            expected = {"int": int, "float": float, "word": str}.get(kind, (int, float, str))
            assert isinstance(value, expected), (kw, statement.loc, value, kind)


def test_unsupported_elements_are_read_with_their_real_layout():
    text = ("HINGE 1 5 14 0 0 1\nRBEAM 2 1 2 5 0. 1. 0.\nBEAMW 3 1 2 3 4 5 6 0 1 0\n"
            "TRUSS 4 1 5\nPLBEAM 5 1 2 3 4\nPLTRUSS 6 1 3\nPLHINGE 7 2 4\nDYNX 2 2 3 4\n"
            "INPUTX 49 1\nEND\nHALT\nINPUTX 49 1 0.5\nXM 7 0.1\nDELINPX 8 4 0.25\n"
            "GRAVITY 0 0 -9.81\nTIMESTEP 1.2 8000\nERROR 1e-4 1e-4\nESIG 1 1.0 2.0\n"
            "USERSIG FFESFVA\nUSERINP \"FFESMVA\"\nOUTLEVEL 0 1\nEND\nHALT\nINPUTF 1 22 3\n"
            "OUTX 2 31 1\nOUTXP 1 22 3\nEND\nEND\n")
    fields = {(s.keyword, s.module): s.fields for s in parse_deck(text)}
    assert fields[("HINGE", 0)] == (1, 5, 14, 0.0, 0.0, 1.0)
    assert fields[("RBEAM", 0)] == (2, 1, 2, 5, 0.0, 1.0, 0.0)
    assert fields[("BEAMW", 0)] == (3, 1, 2, 3, 4, 5, 6, 0.0, 1.0, 0.0)
    assert fields[("INPUTX", 0)] == (49, 1) and fields[("INPUTX", 1)] == (49, 1, 0.5)
    assert fields[("TIMESTEP", 1)] == (1.2, 8000) and isinstance(fields[("TIMESTEP", 1)][1], int)
    assert fields[("USERINP", 1)] == ("FFESMVA",) and fields[("OUTX", 2)] == (2, 31, 1)
    assert fields[("ESIG", 1)] == (1, 1.0, 2.0)


@pytest.mark.parametrize("line, column, message", [
    ("HINGE 1 2", 10, "HINGE takes 3 or 6 fields, got 2 (usage: HINGE e r s [ax ay az])"),
    ("HINGE 1 2 3 0 1", 16, "HINGE takes 3 or 6 fields, got 5 (usage: HINGE e r s [ax ay az])"),
    ("TRUSS 1 2 3 4", 13, "TRUSS takes exactly 3 fields, got 4 (usage: TRUSS e p q)"),
    ("BEAMW 1 1 2 4 5 6", 18, "BEAMW takes 7 or 10 fields, got 6 (usage: BEAMW e p r wp q s wq "
                              "[ox oy oz])"),
    ("TIMESTEP 1.2", 13, "TIMESTEP takes exactly 2 fields, got 1 (usage: TIMESTEP t_end "
                         "n_steps)"),
    ("TIMESTEP 1.2 0.5", 14, "TIMESTEP: expected the number of time steps (a whole number), "
                             "found '0.5'"),
    ("XM 7 1 2", 9, "XM takes 2 or 7 fields, got 3 (usage: XM n m [Ixy Ixz Iyy Iyz Izz])"),
    ("GRAVITY 0 -9.81", 16, "GRAVITY takes exactly 3 fields, got 2 (usage: GRAVITY gx gy gz)"),
    ("USERSIG 3", 9, "USERSIG: expected the name of the user load routine (a word), found '3'"),
    ("OUTX 1 2", 9, "OUTX takes exactly 3 fields, got 2 (usage: OUTX i n c)"),
    ("INPUTX 8 4 0.5", 12, "INPUTX: expected the coordinate number (a whole number), found "
                           "'0.5'"),
])
def test_unsupported_keywords_field_errors_are_meaningful(line, column, message):
    with pytest.raises(DeckError) as info:
        parse_deck(line + "\n")
    assert only_item(info.value) == (1, column, message)


# ------------------------------------------------------------------ syntax errors

def test_unknown_keyword_did_you_mean():
    with pytest.raises(DeckError) as info:
        parse_deck("X 1 0 0 0\n  BEEM 1 1 2 3 4\n", "d.dat")
    assert only_item(info.value) == (2, 3, "unknown keyword 'BEEM' (did you mean BEAM?)")
    text = str(info.value)
    assert text.startswith("d.dat:2:3: error: unknown keyword 'BEEM'")
    assert text.splitlines()[2] == "    " + "  ^"


def test_unknown_keyword_without_close_match():
    with pytest.raises(DeckError) as info:
        parse_deck("QQQQQQ 1\n")
    assert only_item(info.value)[2] == "unknown keyword 'QQQQQQ'"


def test_visualization_keyword_before_final_end():
    with pytest.raises(DeckError) as info:
        parse_deck("COLOR 0 0 0\n")
    assert "VISUALIZATION section" in only_item(info.value)[2]


def test_wrong_field_count_too_few_and_too_many():
    with pytest.raises(DeckError) as info:
        parse_deck("X 1 0 0 0\nBEAM 1 1 2 3\n")
    line, col, msg = only_item(info.value)
    assert (line, col) == (2, 13)
    assert msg.startswith("BEAM takes 5 or 8 fields, got 4")
    with pytest.raises(DeckError) as info:
        parse_deck("X 1 0 0 0 7\n")
    assert only_item(info.value)[:2] == (1, 11)
    assert "X takes 3 to 4 fields, got 5 (usage: X n x y [z])" in only_item(info.value)[2]
    with pytest.raises(DeckError) as info:
        parse_deck("END 1\n")
    assert "END takes no fields, got 1" in only_item(info.value)[2]


def test_word_where_number_expected():
    with pytest.raises(DeckError) as info:
        parse_deck("X 1 zero 0 0\n")
    assert only_item(info.value) == (
        1, 5, "X: expected the x coordinate (m) (a number), found 'zero'")


def test_fraction_where_whole_number_expected():
    with pytest.raises(DeckError) as info:
        parse_deck("BEAM 1 1 2.5 3 4\n", "deck.dat")
    assert only_item(info.value) == (
        1, 10, "BEAM: expected the orientation node at p (a whole number), found '2.5'")


def test_non_positive_node_number():
    with pytest.raises(DeckError) as info:
        parse_deck("X 0 0 0 0\n")
    assert "must be a positive whole number" in only_item(info.value)[2]


def test_bad_character():
    with pytest.raises(DeckError) as info:
        parse_deck("X 1 0 0 0\nX 2 0 @ 0\n", "d.dat")
    assert only_item(info.value)[:2] == (2, 7)
    assert "unexpected character '@'" in only_item(info.value)[2]


def test_malformed_number_and_unterminated_string():
    with pytest.raises(DeckError) as info:
        parse_deck("X 1 0 1abc 0\n")
    assert only_item(info.value)[:2] == (1, 7)
    assert "cannot read '1abc'" in only_item(info.value)[2]
    with pytest.raises(DeckError) as info:
        parse_deck('USERSIG "name\n')
    assert only_item(info.value)[:2] == (1, 9)
    assert "unterminated string" in only_item(info.value)[2]


def test_line_starting_with_number():
    with pytest.raises(DeckError) as info:
        parse_deck("X 1 0 0 0\n1 2 3\n")
    line, col, msg = only_item(info.value)
    assert (line, col) == (2, 1) and "expected a keyword" in msg


def test_text_after_final_end():
    with pytest.raises(DeckError) as info:
        parse_deck(BASE + "END\nEND\nX 9 0 0 0\n")
    assert only_item(info.value)[:2] == (6, 1)
    assert "text after the final END" in only_item(info.value)[2]


def test_spacar_lines_in_the_visualization_section(caplog):
    with pytest.raises(DeckError) as info:
        parse_deck(BASE + "END\nEND\nVISUALIZATION\nX 9 0 0 0\n")
    assert only_item(info.value) == (7, 1, "'X' is not a VISUALIZATION keyword: SPACAR lines "
                                           "must come before the final END END (SPACAR stops "
                                           "reading there)")
    with caplog.at_level(logging.WARNING):
        sts = parse_deck(BASE + "END\nEND\nVISUALIZATION\nCROSSTYPEE RECT\nLIGHTING 1\n")
    assert [s.keyword for s in sts[-2:]] == ["CROSSTYPEE", "LIGHTING"]
    messages = [r.getMessage() for r in caplog.records]
    assert "<deck>:7:1: unknown VISUALIZATION keyword 'CROSSTYPEE' is ignored (did you mean " \
           "CROSSTYPE?)" in messages


def test_halt_must_follow_end():
    with pytest.raises(DeckError) as info:
        parse_deck(BASE + "HALT\n")
    assert only_item(info.value) == (4, 1, "missing END before HALT: HALT must directly follow "
                                           "the END that closes a module")


def test_number_where_a_keyword_was_expected_after_a_short_record():
    with pytest.raises(DeckError) as info:
        parse_deck("X 1 0 0 0\nX 3 1 0 0\nBEAM 1 1 2 3\n  4 0 1 0\n")
    (l1, c1, m1), (l2, c2, m2) = [(loc.line, loc.column, m) for loc, m, _ in info.value.items]
    assert (l2, c2) == (4, 3)
    assert m2 == ("expected a keyword at the start of the line, found the number '4' (is this "
                  "the rest of the BEAM record on line 3? a record must be on one line)")
    with pytest.raises(DeckError) as info:
        parse_deck("X 1 0 0 0\n{2} 3\n")
    assert only_item(info.value)[2] == ("expected a keyword at the start of the line, found the "
                                        "expression '{2}' (every line starts with a keyword "
                                        "such as X, BEAM or FIX)")


def test_keyword_glued_to_its_first_field():
    with pytest.raises(DeckError) as info:
        parse_deck("X1 0 0 0\n")
    assert only_item(info.value) == (1, 1, "unknown keyword 'X1': put a blank between the "
                                           "keyword and the number ('X 1')")


def test_missing_end_at_the_end_and_before_visualization():
    with pytest.raises(DeckError) as info:
        parse_deck(BASE + "END\nHALT\nITERSTEP 10 5\n")
    assert only_item(info.value) == (6, 14, "missing END at the end of the deck: close the "
                                            "last module with END, and the deck with END END "
                                            "(the last module starts at line 5)")
    with pytest.raises(DeckError) as info:
        parse_deck(BASE + "END\nHALT\nITERSTEP 10 5\nVISUALIZATION\nBEAMPROPS 1\n")
    assert only_item(info.value)[:2] == (7, 1)
    assert only_item(info.value)[2].startswith("missing END before VISUALIZATION")
    # one END at the end of the file closes the deck; no END at all is a single module
    assert parse_deck(BASE + "END\nHALT\nITERSTEP 10 5\nEND\n")[-1].keyword == "END"
    assert len(parse_deck(BASE)) == 3


def test_arithmetic_without_braces_is_explained():
    with pytest.raises(DeckError) as info:
        parse_deck("X 1 0 1-2 0\n")
    assert only_item(info.value) == (1, 7, "cannot read '1-2': not a number (numbers look like "
                                           "3, -1.5, .5, 2.0e-3; separate fields with blanks; "
                                           "for arithmetic use braces: {1-2})")


def test_fields_must_be_separated():
    with pytest.raises(DeckError) as info:
        parse_deck('USERSIG "a"b\nX 1 0 0 0"x"\n')
    assert [(loc.line, loc.column) for loc, _, _ in info.value.items] == [(1, 9), (2, 9)]


# ------------------------------------------------------------------ semantic errors

def test_unknown_position_node():
    line, col, msg = only_item(deck_error("X 1 0 0 0\nBEAM 1 1 2 3 4\n"))
    assert (line, col) == (2, 12)
    assert msg == "element 1: position node 3 (at q) has no X line"


def test_position_node_used_as_orientation_node():
    line, col, msg = only_item(deck_error("X 1 0 0 0\nX 3 1 0 0\nBEAM 1 1 3 3 4\n"))
    assert (line, col) == (3, 10)
    assert "node 3 is a position node (X at line 2)" in msg


def test_duplicate_x_names_both_lines():
    line, col, msg = only_item(deck_error(BASE + "X 3 2 0 0\n"))
    assert (line, col) == (4, 3) and "lines 2 and 4" in msg


def test_duplicate_element():
    line, col, msg = only_item(deck_error(BASE + "BEAM 1 3 4 1 2\n"))
    assert (line, col) == (4, 6)
    assert msg == "element 1 is defined twice (lines 3 and 4)"


def test_zero_length_element():
    line, col, msg = only_item(deck_error("X 1 0 0 0\nX 3 0 0 0\nBEAM 7 1 2 3 4\n"))
    assert (line, col) == (3, 1)
    assert "element 7 has zero length" in msg and "nodes 1 and 3" in msg


def test_a_far_node_does_not_make_a_near_element_zero_length():
    """D12: with one node at 1e20 m, a 1 m element elsewhere is not "at the same position":
    an element's length is judged against its own end coordinates, not the model's size."""
    text = ("X 1 1e20 0 0\nX 3 1 0 0\nX 5 2 0 0\nBEAM 1 1 2 3 4\nBEAM 2 3 4 5 6\n"
            "DYNE 1:2 1:6\nFIX 1\nFIX 2\nEND\nHALT\nESTIFF 1:2 1 1 1 1\nEND\nEND\n")
    model = model_from_text(text)
    assert model.elements["BEAM"].n_elem == 2
    # nodes that do coincide within their own round-off still do
    _, _, msg = only_item(deck_error("X 1 1e20 0 0\nX 3 1e20 0 0\nBEAM 7 1 2 3 4\n"))
    assert "element 7 has zero length" in msg


def test_parallel_orientation_vector():
    line, col, msg = only_item(deck_error("X 1 0 0 0\nX 3 1 0 0\nBEAM 1 1 2 3 4 2 0 0\n"))
    assert (line, col) == (3, 16)
    assert "parallel to the element axis" in msg


def test_zero_orientation_vector():
    line, col, msg = only_item(deck_error("X 1 0 0 0\nX 3 1 0 0\nBEAM 1 1 2 3 4 0 0 0\n"))
    assert (line, col) == (3, 16) and "(nearly) zero" in msg


def test_dyne_mode_seven():
    line, col, msg = only_item(deck_error(BASE + "DYNE 1 1 7\nESTIFF 1 1 1 1 1\n"))
    assert (line, col) == (4, 10)
    assert "deformation modes 1 to 6, got 7" in msg


def test_dyne_without_estiff():
    line, col, msg = only_item(deck_error(BASE + "DYNE 1 2\n"))
    assert (line, col) == (4, 8)
    assert msg == ("element 1 mode 2 is flexible (DYNE) but has no stiffness: "
                   "add ESTIFF 1 EA GJ EIy EIz")


def test_dyne_with_zero_stiffness():
    line, col, msg = only_item(deck_error(BASE + "DYNE 1 1 2\nESTIFF 1 1 0 1 1\n"))
    assert (line, col) == (4, 10)
    assert "mode 2 is flexible (DYNE) but the stiffness GJ is zero" in msg


def test_dyne_without_modes_and_both_dyne_and_rlse():
    err = deck_error(BASE + "DYNE 1\nDYNE 1 3\nRLSE 1 3\nESTIFF 1 1 1 1 1\n")
    msgs = [(loc.line, msg) for loc, msg, _ in err.items]
    assert msgs[0][0] == 4 and "expected deformation mode numbers" in msgs[0][1]
    assert msgs[1][0] == 6 and "listed in both DYNE (line 5) and RLSE (line 6)" in msgs[1][1]


def test_element_data_for_unknown_element():
    err = deck_error(BASE + "DYNE 5 1\nESTIFF 5 1 1 1 1\nEM 5 1\n")
    assert [(loc.line, loc.column) for loc, _, _ in err.items] == [(4, 6), (5, 8), (6, 4)]
    assert all("element 5 is not defined" in msg for _, msg, _ in err.items)


def test_estiff_too_few_and_negative():
    err = deck_error(BASE + "ESTIFF 1 1 2\nEM 1 -1\n")
    assert "needs EA GJ EIy EIz" in err.items[0][1]
    assert err.items[1][0].line == 5 and "rhoA must not be negative" in err.items[1][1]
    line, col, msg = only_item(deck_error(BASE + "ESTIFF 1 1 -2 3 4\n"))
    assert (line, col) == (4, 12) and "GJ must not be negative" in msg


def test_fix_coordinate_five_on_position_node():
    line, col, msg = only_item(deck_error(BASE + "FIX 1 5\n"))
    assert (line, col) == (4, 7)
    assert msg == "FIX: node 1 is a position node with coordinates 1 to 3, got 5"
    # coordinate 4 is fine on an orientation node, 5 is not
    assert build(BASE + "FIX 2 4\n").fixes[0].coords == (4,)
    assert "orientation node with coordinates 1 to 4" in only_item(
        deck_error(BASE + "FIX 2 5\n"))[2]


def test_fix_and_load_on_unknown_node():
    err = deck_error(BASE + "FIX 8\nXF 9 1 0 0\n")
    assert [(loc.line, loc.column) for loc, _, _ in err.items] == [(4, 5), (5, 4)]
    assert "node 8 is not defined" in err.items[0][1]


def test_user_routine_lines_one_error_each():
    """USERSIG/USERINP name Python functions (docs/user-routines.md): a name that cannot be
    one, USERINP without input coordinates, and a repeat are each one error at its line."""
    err = deck_error(BASE + 'USERSIG "f-g"\nUSERINP g\nUSERINP h\n')
    assert [(loc.line, msg.split(":")[0]) for loc, msg, _ in err.items] == [
        (4, "USERSIG"), (5, "USERINP"), (6, "USERINP is given twice (lines 5 and 6)")]
    assert "'f-g' cannot name a Python function" in err.items[0][1]
    assert "the deck declares none: add INPUTX or INPUTE lines" in err.items[1][1]


def test_several_errors_reported_at_once_ordered_by_line():
    text = ("X 1 0 0 0\nX 3 0 0 0\nBEAM 1 1 2 3 4\nBEAM 2 1 2 9 4\n"
            "DYNE 1 7\nFIX 3 5\nDYNX 3 4\n")
    err = deck_error(text)
    lines = [loc.line for loc, _, _ in err.items]
    assert lines == sorted(lines) and lines == [3, 4, 5, 6, 7]
    assert str(err).endswith("5 errors")
    assert "t.dat:4:12: error: element 2: position node 9 (at q) has no X line" in str(err)


def test_several_syntax_errors_reported_at_once():
    with pytest.raises(DeckError) as info:
        parse_deck("X 1 a 0 0\nBEEM 1\nFIX x\n")
    assert [loc.line for loc, _, _ in info.value.items] == [1, 2, 3]


def test_load_on_a_fixed_coordinate():
    text = BASE + "FIX 1\nFIX 2 2 3\nFIX 3 2\nXF 1 0 0 0\nXF 3 5 0 0\nDELXF 3 0 1 0\n" \
                  "DELXF 2 0 0 7\nDELXF 2 4 0 0\n"
    err = deck_error(text)
    assert [(loc.line, loc.column, msg) for loc, msg, _ in err.items] == [
        (9, 11, "DELXF 3: the force along y acts on the fixed coordinate y of node 3 (FIX at "
                "line 6); it would go straight into the support: remove the load component or "
                "the FIX"),
        (11, 9, "DELXF 2: the moment about x acts on the fixed Euler parameter lambda1 of node "
                "2, which cannot turn about x (FIX at line 5); it would go straight into the "
                "support: remove the load component or the FIX")]
    # zero components, free coordinates and moments about a free axis are fine
    m = build(BASE + "FIX 1\nFIX 2 2 3\nXF 1 0 0 0\nDELXF 2 0 0 7\nDELXF 3 1 1 1\n")
    assert len(m.loads) == 3


def test_nodal_masses():
    m = build(BASE + "FIX 1\nFIX 2\nXM 3 0.5\nXM 4 1 0.1 0 2 0 3\nXM 3 0.25\n")
    assert [(x.node, x.values) for x in m.nodal_masses] == [
        (3, (0.5,)), (4, (1.0, 0.1, 0.0, 2.0, 0.0, 3.0)), (3, (0.25,))]
    err = deck_error(BASE + "XM 3 1 0 0 1 0 1\nXM 4 1\nXM 3 -1\nXM 4 1 5 0 1 0 1\nXM 9 1\n")
    assert [(loc.line, msg) for loc, msg, _ in err.items] == [
        (4, "XM: node 3 is a position node: give its mass only (XM 3 m)"),
        (5, "XM: node 4 is an orientation node: give its inertia tensor (XM 4 Ixx Ixy Ixz Iyy "
            "Iyz Izz)"),
        (6, "XM: the mass must not be negative, got -1"),
        (7, "XM: the inertia tensor of node 4 is not positive semi-definite (a negative "
            "principal inertia -4)"),
        (8, "XM: node 9 is not defined (no X line and not used by any element)")]


# ------------------------------------------------------------------ robustness

_TOKENS = ["BEAM", "END", "X", "HALT", "FIX", "DYNE", "RLSE", "ESTIFF", "XF", "ITERSTEP", "MODE",
           "HINGE", "VISUALIZATION", "SET", "INCLUDE", "BEAMS", "BEAMARC", "XM", "CROSSTYPE",
           "1", "2", "7", "0", "-3", "2.5", "1e400", "-1e-3", ".", "abc", '"s"', "#", "%", "\n",
           "\t", "1abc", "{", "}", "{2*pi}", "{1/0}", "{n}", "1:3", "1:{n}", "3:1", ":", "1:0:2",
           "2147483648", "{2147483647+1}"]
_CHARS = list("0123456789 .-+eE#%\"\n\r\tXxBEAMENDé@,;{}:^*/()") + ["\x00", "\x0c",
                                                                         "\u2028"]


def _fuzz_seeds() -> list[tuple[str, str]]:
    """Real decks (the corpus), the generator-based paper decks and VALID."""
    seeds = [("t.dat", VALID)]
    root = Path(__file__).resolve().parents[1]
    seeds += [(str(p), p.read_text()) for p in sorted((root / "decks").glob("table2_*.dat"))]
    if CORPUS.is_dir():
        seeds += [(str(p), p.read_text(encoding="latin-1")) for p in sorted(CORPUS.glob("*.dat"))]
    return seeds


_SEEDS = _fuzz_seeds()


@st.composite
def mutated_decks(draw):
    name, text = draw(st.sampled_from(_SEEDS))
    for _ in range(draw(st.integers(1, 4))):
        if draw(st.booleans()):                       # character level
            i = draw(st.integers(0, len(text)))
            op = draw(st.sampled_from(["delete", "duplicate", "insert"]))
            if op == "delete":
                text = text[:i] + text[i + 1:]
            elif op == "duplicate":
                text = text[:i] + text[i:i + 1] + text[i:]
            else:
                text = text[:i] + draw(st.sampled_from(_CHARS)) + text[i:]
        else:                                         # token level
            parts = re.split(r"(\s+)", text)
            words = [k for k, p in enumerate(parts) if p and not p.isspace()]
            k = draw(st.sampled_from(words)) if words else 0
            op = draw(st.sampled_from(["delete", "duplicate", "insert", "replace"]))
            if op == "delete":
                parts[k] = ""
            elif op == "duplicate":
                parts[k] = parts[k] + " " + parts[k]
            elif op == "insert":
                parts[k] = draw(st.sampled_from(_TOKENS)) + " " + parts[k]
            else:
                parts[k] = draw(st.sampled_from(_TOKENS))
            text = "".join(parts)
    return name, text


@pytest.mark.slow
@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(mutated_decks())
def test_mutated_decks_only_raise_deck_errors(deck):
    """Randomly mutated real decks either build or raise DeckError, every item with a valid
    location in the deck (never another exception)."""
    name, text = deck
    n_lines = text.count("\n") + 1
    try:
        statements = parse_deck(text, name)
        try:
            build_model(statements, text=text, path=name)
        except DeckError as exc:
            assert summarize(statements, None, path=name, problems=exc.items).format()
            raise
    except DeckError as exc:
        assert exc.loc is not None
        for loc, msg, src in exc.items:
            assert loc is not None and loc.file == name and msg
            assert 1 <= loc.line <= n_lines and loc.column >= 1
            assert src is None or src == text.split("\n")[loc.line - 1].rstrip("\r")
        assert str(exc)
    # warnings are allowed; anything but DeckError propagates and fails the test


def test_nan_never_leaks_into_coordinates():
    m = build(VALID)
    assert all(math.isfinite(v) for v in m.position_x0.ravel())
