"""Compiled Lark parsers of spacarpy's grammars, cached on disk between processes.

Compiling a LALR grammar (``deck/grammar.lark``, ``expr.lark``) takes tens of milliseconds
at every start of ``spacarpy run``. :func:`lalr_parser` compiles a grammar once and keeps the
compiled parser (``Lark.save``) in the user's cache folder (``$XDG_CACHE_HOME/spacarpy`` or
``~/.cache/spacarpy``); later processes load it (``Lark.load``) in a few milliseconds.

The cache file's name holds the SHA-256 of the grammar text, the options, and the Lark and
Python versions, so an edited grammar or another Lark never loads a stale parser. A cache is
written to a temporary file and renamed into place (atomic: parallel sweep workers never see a
half-written file); a cache that cannot be read or written (read-only home, damaged file) is
ignored and the grammar compiled as before. ``SPACARPY_NO_GRAMMAR_CACHE=1`` turns the cache
off. The parser is the same either way: Lark's own save/load round trip.
"""
from __future__ import annotations

import hashlib
import os
import sys
import tempfile
from pathlib import Path

from lark import Lark
from lark import __version__ as _LARK_VERSION

__all__ = ["cache_folder", "lalr_parser"]


def cache_folder() -> Path:
    """The folder of the compiled-parser cache (not created here)."""
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "spacarpy"


def lalr_parser(grammar: Path, **options) -> Lark:
    """The LALR parser of the grammar file ``grammar`` with Lark ``options``, from the cache
    when a matching one is there, else compiled (and cached when the folder is writable)."""
    text = grammar.read_text(encoding="utf-8")
    if os.environ.get("SPACARPY_NO_GRAMMAR_CACHE"):
        return Lark(text, parser="lalr", **options)
    key = hashlib.sha256("\n".join([
        text, repr(sorted(options.items())), _LARK_VERSION, sys.version,
    ]).encode("utf-8")).hexdigest()[:32]
    path = cache_folder() / f"{grammar.stem}-{key}.lark"
    try:
        with open(path, "rb") as f:
            return Lark.load(f)
    except Exception:       # absent, unreadable or damaged (any error): compile instead
        pass
    parser = Lark(text, parser="lalr", **options)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.name, suffix=".tmp")
        try:
            with os.fdopen(fd, "wb") as f:
                parser.save(f)
            os.replace(tmp, path)
        except BaseException:
            os.unlink(tmp)
            raise
    except OSError:         # read-only or full disk: no cache, same parser
        pass
    return parser
