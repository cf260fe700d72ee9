"""spacarpy: large-deflection analysis of flexible multibody systems with the DDM beam.

Reads SPACAR-style decks, solves with the discrete-deformation-mode beam element of
Jonker & Meijaard (2013), writes HDF5 results. Entry points: the ``spacarpy`` command
(:mod:`spacarpy.cli`), :func:`spacarpy.deck.load_deck` and
:func:`spacarpy.solvers.static.solve_static`.
"""
__version__ = "0.1.0"
