"""Write the generated decks of decks/: the paper's Tables 1-3 and the closed-form checks of
the linearized analyses.

Run from anywhere: ``python decks/make_paper_decks.py``. The deck text comes from
:mod:`spacarpy.bench.cases`; the committed decks must equal what this script writes (a test checks).
"""
from pathlib import Path

from spacarpy.bench.cases import (
    bend_deck,
    cantilever_deck,
    cantilever_modes_deck,
    column_deck,
    free_free_deck,
    lateral_buckling_deck,
)

HERE = Path(__file__).resolve().parent


def paper_decks() -> dict[str, str]:
    """File name -> deck text for every generated deck shipped in decks/."""
    decks = {}
    for variant in ("modified", "basic"):
        for n in (1, 2, 4, 8, 16, 32, 64, 128):
            decks[f"table1_cantilever_{n}el_{variant}.dat"] = cantilever_deck(n, variant)
        decks[f"table2_bend_8el_{variant}.dat"] = bend_deck(8, variant)
        for n in (1, 2, 4):
            decks[f"table3_lateral_buckling_{n}el_{variant}.dat"] = \
                lateral_buckling_deck(n, variant)
    decks["table2_bend_48el_modified.dat"] = bend_deck(48, "modified")
    decks["cantilever_modes_16el.dat"] = cantilever_modes_deck(16)
    decks["free_free_beam_8el.dat"] = free_free_deck(8)
    decks["column_pinned_buckling_16el.dat"] = column_deck(16, "pinned")
    decks["column_clamped_buckling_16el.dat"] = column_deck(16, "clamped")
    decks["column_pinned_axial_load_16el.dat"] = column_deck(16, "pinned", "eigen", -1.2, 12)
    return decks


if __name__ == "__main__":
    for name, text in paper_decks().items():
        (HERE / name).write_text(text)
        print("wrote", HERE / name)
