"""Write the decks that reproduce Tables 1 and 2 of Jonker & Meijaard (2013).

Run from anywhere: ``python decks/make_paper_decks.py``. The deck text comes from
:mod:`spacarpy.cases`; the committed decks must equal what this script writes (a test checks).
"""
from pathlib import Path

from spacarpy.cases import bend_deck, cantilever_deck

HERE = Path(__file__).resolve().parent


def paper_decks() -> dict[str, str]:
    """File name -> deck text for every paper deck shipped in decks/."""
    decks = {}
    for variant in ("modified", "basic"):
        for n in (1, 2, 4, 8, 16, 32, 64, 128):
            decks[f"table1_cantilever_{n}el_{variant}.dat"] = cantilever_deck(n, variant)
        decks[f"table2_bend_8el_{variant}.dat"] = bend_deck(8, variant)
    decks["table2_bend_48el_modified.dat"] = bend_deck(48, "modified")
    return decks


if __name__ == "__main__":
    for name, text in paper_decks().items():
        (HERE / name).write_text(text)
        print("wrote", HERE / name)
