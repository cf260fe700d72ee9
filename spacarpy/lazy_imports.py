"""Process start-up: numpy's optional submodules that importing scipy touches, made lazy.

scipy (1.15-1.17 at least) vendors ``array_api_compat``, whose numpy namespace is a clone of
``numpy``'s: it asks ``hasattr(numpy, name)`` for every name ``dir(numpy)`` lists, and numpy
imports a lazily-exposed submodule on that question. So importing ``scipy.sparse`` also
imports ``numpy.testing``, ``numpy.f2py``, ``numpy.ma``, ``numpy.polynomial`` and a few more,
about 90 modules and 70-100 ms of CPU: a fifth of the whole run of a small deck, for modules
no analysis uses.

:func:`defer_numpy_submodules` registers those submodules with the standard library's
:class:`importlib.util.LazyLoader` before scipy is imported: each is a module object whose
code runs on its first attribute access. Nothing changes for a caller: ``numpy.testing``,
``import numpy.ma`` and ``from numpy.polynomial import Polynomial`` work as before, they only
load when used. It is called only where a process starts (:func:`spacarpy.cli.console`, the
batch workers), never on ``import spacarpy``, so a program that imports spacarpy keeps its
own import order. Any failure leaves numpy as it was: the loss is start-up time only.
"""
from __future__ import annotations

import importlib.util
import sys

__all__ = ["DEFERRED", "defer_numpy_submodules"]

#: The submodules made lazy: those the clone touches and no spacarpy analysis uses. (scipy
#: itself uses ``numpy.random``, ``numpy.fft``, ``numpy.typing`` and ``numpy.dtypes``; they
#: would load at once anyway.)
DEFERRED = ("testing", "f2py", "ma", "polynomial", "ctypeslib", "rec", "char", "strings")


def defer_numpy_submodules() -> list[str]:
    """Register numpy's :data:`DEFERRED` submodules, those not imported yet, as lazy modules.

    Returns the full names registered (none when scipy, or the submodule, is already
    imported, or when the import machinery does not allow it)."""
    if "scipy" in sys.modules:          # too late to matter; and never change a live setup
        return []
    import numpy
    done = []
    for name in DEFERRED:
        full = f"numpy.{name}"
        if full in sys.modules or name in vars(numpy):
            continue
        try:
            spec = importlib.util.find_spec(full)
            if spec is None or spec.loader is None or not hasattr(spec.loader, "exec_module"):
                continue
            loader = importlib.util.LazyLoader(spec.loader)
            spec.loader = loader
            module = importlib.util.module_from_spec(spec)
            sys.modules[full] = module
            loader.exec_module(module)
        except Exception:               # noqa: BLE001 - start-up time only; numpy as it was
            sys.modules.pop(full, None)
            continue
        setattr(numpy, name, module)
        done.append(full)
    return done
