"""The command line's layout (issue 31): one module of spacarpy.cli per subcommand, with its
arguments and its handler, and a parser built once per process."""
from __future__ import annotations

import argparse
import importlib


def _subcommands(parser: argparse.ArgumentParser) -> list[str]:
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return list(action.choices)


def test_every_subcommand_has_its_module_with_parser_and_handler():
    from spacarpy.cli.main import build_parser
    names = _subcommands(build_parser())
    assert names == ["run", "check", "bench", "validate", "show", "extract", "plot", "export",
                     "batch", "sweep"]
    for name in names:
        module = importlib.import_module(f"spacarpy.cli.{name}")
        assert callable(module.add_parser), name
        assert callable(getattr(module, f"cmd_{name}")), name
        # the module's own parser adds exactly its subcommand
        sub = argparse.ArgumentParser().add_subparsers()
        if name in ("extract", "plot"):
            module.add_parser(sub, False)
        else:
            module.add_parser(sub)
        assert list(sub.choices) == [name]


def test_the_parser_is_built_once_per_process():
    from spacarpy.cli.main import _parser
    assert _parser(False) is _parser(False)
    assert _parser(True) is not _parser(False)
