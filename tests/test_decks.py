"""Shipped decks and documentation examples: generated decks are up to date, and the README's
example deck runs and gives the paper's numbers."""
import re
import runpy
from pathlib import Path

import pytest

from spacarpy.deck import build_model, parse_deck
from spacarpy.solvers.statics.static import solve_static

ROOT = Path(__file__).resolve().parents[1]


def test_committed_paper_decks_equal_the_generator_output():
    decks = runpy.run_path(str(ROOT / "decks" / "make_paper_decks.py"))["paper_decks"]()
    assert len(decks) == 30
    for name, text in decks.items():
        assert (ROOT / "decks" / name).read_text() == text, f"{name} is stale: rerun the script"


def test_readme_example_deck_reproduces_table1_two_elements():
    readme = (ROOT / "README.md").read_text()
    text = re.search(r"```text\n(.*?)```", readme, re.S).group(1)
    model = build_model(parse_deck(text, "README.md"), text=text, path="README.md")
    res = solve_static(model)
    tip = res.steps[-1].x[res.problem.num.pos_idx[-1]]
    # Table 1, 2 elements, modified deformations (torsion stiffness does not matter here)
    assert round(2.0 - tip[0], 6) == pytest.approx(0.574104, abs=1e-12)
    assert round(tip[1], 6) == pytest.approx(1.276622, abs=1e-12)
