"""EXPECT lines (spacarpy extension): parsing with file:line:col errors, checking a result
file, and ``spacarpy run`` exit code 4."""
import math
import shutil
from pathlib import Path

import pytest

from spacarpy.cli import main
from spacarpy.deck import parse_deck
from spacarpy.deck.expect import EXIT_EXPECTATION, expectations
from spacarpy.errors import DeckError

DECKS = Path(__file__).resolve().parents[1] / "decks"


def parse(text):
    return expectations(parse_deck(text, "deck.dat"))


def test_syntax_selectors_and_default_tolerance():
    ex = parse("SET F 2\nEXPECT static.displacement -1 17 y 1.211296\n"
               "EXPECT static.position 0 3 2 46.94\n"
               "EXPECT static.reaction -1 1 fy -1.5e3 rel 1e-6 abs 0.5\n"
               "EXPECT buckling.critical_load_multiplier -1 {2*F} abs {1e-3*F}\n"
               "EXPECT buckling.critical_load_multiplier -1 inf\n"
               "EXPECT run.exit_code 1\n")
    assert [e.quantity for e in ex] == ["static.displacement", "static.position",
                                       "static.reaction", "buckling.critical_load_multiplier",
                                       "buckling.critical_load_multiplier", "run.exit_code"]
    assert ex[0].selectors == (-1, 17, 2) and ex[0].abs_tol == pytest.approx(5e-7)
    assert ex[1].selectors == (0, 3, 2) and ex[1].abs_tol == pytest.approx(0.005)
    assert ex[2].selectors == (-1, (1, "Fy")) and (ex[2].abs_tol, ex[2].rel_tol) == (0.5, 1e-6)
    assert ex[3].value == 4.0 and ex[3].abs_tol == pytest.approx(2e-3)
    assert math.isinf(ex[4].value) and ex[4].tolerance == 0
    assert ex[5].value == 1


@pytest.mark.parametrize("line,col,message", [
    ("EXPECT static.positon -1 3 x 1.0", 8, "unknown quantity 'static.positon' (did you mean "
                                            "static.position?)"),
    ("EXPECT static.position -1 3 q 1.0", 29, "expected a component x, y or z"),
    ("EXPECT static.position -1 3 1.0", 29, "static.position takes 3 selectors"),
    ("EXPECT eigen.frequency -1 1 {2*3}", 29, "give a tolerance"),
    ("EXPECT eigen.frequency -1 0 1.0", 27, "expected a mode number"),
    ("EXPECT static.reaction -1 1 Fq 1.0", 29, "expected a reaction component"),
    ("EXPECT eigen.frequency -1 1 1.0 abs -1", 37, "tolerance must be a finite number"),
])
def test_errors_name_file_line_column(line, col, message):
    with pytest.raises(DeckError) as err:
        parse("X 1 0 0 0\n" + line + "\n")
    text = str(err.value)
    assert text.startswith(f"deck.dat:2:{col}: error: EXPECT: ")
    assert message in text


def test_run_checks_expectations_and_exits_4_on_failure(tmp_path, capsys):
    deck = tmp_path / "t.dat"
    shutil.copy(DECKS / "table1_cantilever_2el_modified.dat", deck)
    assert main(["run", str(deck), "-q"]) == 0
    out = capsys.readouterr().out
    assert out.count("PASS") == 2 and "expectations: 2 passed, 0 failed" in out
    text = deck.read_text().replace("EXPECT static.displacement -1 5 y 1.276622",
                                    "EXPECT static.displacement -1 5 y 1.276632")
    deck.write_text(text)
    assert main(["run", str(deck), "-q"]) == EXIT_EXPECTATION == 4
    out = capsys.readouterr().out
    assert "FAIL  static.displacement[-1 5 2]  expected 1.276632" in out
    assert deck.with_suffix(".h5").exists()         # the results are still written


def test_unreadable_value_fails_with_reason(tmp_path, capsys):
    deck = tmp_path / "t.dat"
    text = (DECKS / "table1_cantilever_1el_modified.dat").read_text()
    deck.write_text(text.replace("ITERSTEP", "EXPECT eigen.frequency -1 1 1.0 rel 1e-3\n"
                                             "EXPECT static.position -1 1 x 99.0\nITERSTEP"))
    assert main(["run", str(deck), "-q"]) == 4
    out = capsys.readouterr().out
    assert "/eigen/frequency is not in the result file" in out
    assert "FAIL  static.position[-1 1 1]" in out


def test_unknown_node_or_element_is_refused_before_the_run(tmp_path, capsys):
    deck = tmp_path / "t.dat"
    text = (DECKS / "table1_cantilever_1el_modified.dat").read_text()
    deck.write_text(text.replace("ITERSTEP", "EXPECT static.position -1 99 x 1.0\n"
                                             "EXPECT static.deformation -1 7 1 0.0\nITERSTEP"))
    line = text[:text.index("ITERSTEP")].count("\n") + 1
    assert main(["run", str(deck), "-q"]) == 2
    err = capsys.readouterr().err
    assert f"t.dat:{line}:27" in err and "position node 99 is not in the model" in err
    assert f"t.dat:{line + 1}:30" in err and "element 7 is not in the model" in err
    assert "Traceback" not in err
    assert not deck.with_suffix(".h5").exists()        # refused before any work


@pytest.mark.parametrize("name", ["table2_bend_8el_modified", "table3_lateral_buckling_2el_basic",
                                  "table3_lateral_buckling_1el_basic"])
def test_paper_decks_carry_and_meet_the_papers_numbers(tmp_path, capsys, name):
    assert "EXPECT " in (DECKS / f"{name}.dat").read_text()
    assert main(["run", str(DECKS / f"{name}.dat"), "-o", str(tmp_path / "o.h5"), "-q"]) == 0
    out = capsys.readouterr().out
    assert "FAIL" not in out and "0 failed" in out


def test_failure_is_only_a_warning_when_the_command_line_changes_the_deck(tmp_path, capsys):
    out = tmp_path / "o.h5"
    deck = str(DECKS / "table1_cantilever_4el_modified.dat")
    assert main(["run", deck, "--deformations", "basic", "-o", str(out), "-q"]) == 0
    assert "FAIL" in capsys.readouterr().out
