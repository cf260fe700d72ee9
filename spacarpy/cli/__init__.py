"""The ``spacarpy`` command line, one module per subcommand (its arguments and its handler:
``run``, ``check``, ``bench``, ``validate``, ``show``, ``extract``, ``plot``, ``export``,
``batch``, ``sweep``), the pieces they share (:mod:`spacarpy.cli.common`), the process
around a command (:mod:`spacarpy.cli.process`: BLAS threads, signals, error messages, exit)
and :mod:`spacarpy.cli.main` (the parser, the dispatch, :func:`main` and :func:`console`)."""
from spacarpy.cli.main import console, main

__all__ = ["console", "main"]
