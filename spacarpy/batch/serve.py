"""The loop of a batch worker process (``python -m spacarpy.batch.serve``): runs ``spacarpy``
command lines in-process, one per request, with spacarpy imported once.

The caller's side, the protocol and the isolation are in :mod:`spacarpy.batch.workers`; this
module is separate because it imports the command line (:mod:`spacarpy.cli`), which imports
the batch machinery.
"""
from __future__ import annotations

import contextlib
import io
import json
import os
import sys

__all__ = ["serve"]


def serve() -> None:
    """The worker's loop: read requests on stdin, answer on the original stdout."""
    answers = os.fdopen(os.dup(1), "w", encoding="utf-8")
    os.dup2(2, 1)                       # native writes to fd 1 go to stderr, not the answers
    import spacarpy.deck  # noqa: F401  (imported once, before the first request)
    import spacarpy.run  # noqa: F401
    from spacarpy.cli import main
    while line := sys.stdin.readline():
        request = json.loads(line)
        out, err = io.StringIO(), io.StringIO()
        os.chdir(request["cwd"])
        sys.stdin, requests = io.StringIO(), sys.stdin     # a run reads no requests
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                rc = main(list(request["argv"]))
            except SystemExit as exc:
                rc = exc.code if isinstance(exc.code, int) else 1
            except BaseException as exc:    # noqa: BLE001 - reported as the run's failure
                print(f"internal error: {type(exc).__name__}: {exc}", file=sys.stderr)
                rc = 1
        sys.stdin = requests
        answers.write(json.dumps({"rc": rc, "stdout": out.getvalue(),
                                  "stderr": err.getvalue()}) + "\n")
        answers.flush()


if __name__ == "__main__":
    from spacarpy.lazy_imports import defer_numpy_submodules
    defer_numpy_submodules()    # one thread, runs as `spacarpy run` does (cli.console)
    serve()
    from spacarpy.cli.process import exit_process
    exit_process(0)             # no interpreter teardown: the caller waits for this exit
