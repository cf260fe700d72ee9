"""``spacarpy bench`` and its reference problems: :mod:`~spacarpy.bench.runner` (the
benchmark: every case and size timed in a fresh process), :mod:`~spacarpy.bench.decks` (the
cases' names, sizes and decks), :mod:`~spacarpy.bench.tables` (the text and Markdown
tables), :mod:`~spacarpy.bench.cases` (the papers' reference cantilever, bend, lateral
buckling and arc-length column decks), :mod:`~spacarpy.bench.spinup` (Simo & Vu-Quoc's
spin-up) and :mod:`~spacarpy.bench.peers` (the same problems in Exudyn)."""
