"""Memory of large models: the allocator setting (glibc only) and the estimate before a run.

:func:`estimate_run_bytes` and :func:`available_bytes` let ``spacarpy run`` stop a model that
would not fit before it starts (the estimate is also printed by ``spacarpy check``), and
:func:`check_factor_memory` stops a supernodal factorization whose ordering (its fill, from
the analysis that precedes the numerical work) needs more memory than is available.

Every kernel call at 10^5 elements allocates arrays of tens to hundreds of megabytes. glibc
serves allocations above 32 MB with fresh ``mmap`` pages and hands them back to the system
on release, so every such array pays the page faults of first touch again (about 1 ms per
MB on the benchmark machine). :func:`keep_freed_memory` makes glibc serve them from its heap
and keep freed memory for reuse: the 10^5-element cantilever of ``spacarpy bench`` solves in
82 s instead of 106 s, with the same iterates. The price is a process that does not return
memory to the system before it ends, which suits the command-line program; it is called by
``spacarpy``'s commands, not on import. ``SPACARPY_KEEP_MEMORY=0`` switches it off; on other
C libraries it does nothing.
"""
from __future__ import annotations

import ctypes
import logging
import os
from contextvars import ContextVar

from spacarpy.errors import EXIT_INPUT, SpacarError

log = logging.getLogger(__name__)

_M_TRIM_THRESHOLD, _M_TOP_PAD, _M_MMAP_MAX = -1, -2, -4      # glibc's malloc.h
_done = False


def keep_freed_memory() -> bool:
    """Ask glibc to reuse freed memory instead of returning it; True if it took effect."""
    global _done
    if _done:
        return True
    if os.environ.get("SPACARPY_KEEP_MEMORY", "1") == "0":
        return False
    try:
        mallopt = _libc().mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes, mallopt.restype = [ctypes.c_int, ctypes.c_int], ctypes.c_int
    ok = (mallopt(_M_MMAP_MAX, 0) == 1                     # no mmap: all from the heap
          and mallopt(_M_TRIM_THRESHOLD, 2**31 - 1) == 1   # never trim the heap's top
          and mallopt(_M_TOP_PAD, 256 * 2**20) == 1)       # grow it in 256 MB steps
    _done = ok
    return ok


def _libc():
    """glibc by its usual name; else the name ``ctypes.util`` finds (which costs 20 ms of
    start-up: it imports more modules and runs ``ldconfig``)."""
    try:
        return ctypes.CDLL("libc.so.6")
    except OSError:
        from ctypes.util import find_library
        return ctypes.CDLL(find_library("c") or "libc.so.6")


# -- memory estimate before a run ------------------------------------------------------------

#: Peak resident memory of ``spacarpy run`` ~ BASE + PER_ELEMENT * elements, on the static
#: cantilever of ``spacarpy bench`` (docs/performance.md, "Memory estimate before a run"):
#: measured 75 MB at 10 elements, 120 MB at 10^3, 541-623 MB at 10^4 and 3342 MB at 10^5
#: (estimates 110, 141, 422 and 3235 MB: within a factor 1.5 at every size). The 10-mode
#: eigen runs measured 489 MB at 10^4 and 4080 MB at 10^5 (their ARPACK vectors). A 3D model
#: factorized by PARDISO adds its factors, which the analysis of each factorization reports
#: and :func:`check_factor_memory` checks before the numerical work.
BASE_BYTES = 110 * 2**20
PER_ELEMENT_BYTES = 32 * 2**10


def estimate_run_bytes(n_elem: int) -> int:
    """An estimate of the peak memory of a run of a model of ``n_elem`` elements, in bytes."""
    return BASE_BYTES + PER_ELEMENT_BYTES * int(n_elem)


def available_bytes() -> int | None:
    """Memory this process can still use, in bytes: ``MemAvailable`` of /proc/meminfo, lower
    if a cgroup (v2) limit says so; None where neither can be read (not Linux)."""
    found = []
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    found.append(int(line.split()[1]) * 1024)
                    break
    except (OSError, ValueError, IndexError):
        pass
    try:
        with open("/sys/fs/cgroup/memory.max") as fh:
            limit = fh.read().strip()
        if limit.isdigit():
            with open("/sys/fs/cgroup/memory.current") as fh:
                found.append(int(limit) - int(fh.read().strip()))
    except (OSError, ValueError):
        pass
    return min(found) if found else None


def format_bytes(n: int) -> str:
    """``n`` bytes as MB below 10 GB, else GB."""
    return f"{n / 2**20:.0f} MB" if n < 10 * 2**30 else f"{n / 2**30:.1f} GB"


class MemoryLimitError(SpacarError):
    """The model would need more memory than is available (exit 2)."""

    exit_code = EXIT_INPUT


def memory_line(n_elem: int) -> str:
    """``about 603 MB at the peak of a run``: the estimate as ``spacarpy check`` shows it
    (without the available memory, which changes from moment to moment)."""
    return f"about {format_bytes(estimate_run_bytes(n_elem))} at the peak of a run"


def check_memory(n_elem: int, ignore: bool = False) -> None:
    """Stop before the solve when the estimate exceeds the available memory, rather than
    grow until the OOM killer ends the run; with ``ignore`` only warn.

    Raises
    ------
    MemoryLimitError
        With the estimate and the available memory.
    """
    need, have = estimate_run_bytes(n_elem), available_bytes()
    log.debug("memory estimate: %s", memory_line(n_elem))
    if have is None or need <= have:
        return
    text = (f"the model of {n_elem} elements needs about {format_bytes(need)} of memory, "
            f"more than the {format_bytes(have)} available")
    if ignore:
        log.warning("%s; running anyway (--ignore-memory-limit)", text)
        return
    raise MemoryLimitError(f"error: {text}. Reduce the model, free memory, or run anyway "
                           f"with --ignore-memory-limit")


#: ``spacarpy run --ignore-memory-limit``: :func:`check_factor_memory` then only warns.
IGNORE_LIMIT: ContextVar[bool] = ContextVar("spacarpy_ignore_memory_limit", default=False)


def check_factor_memory(factor_bytes: int, unknowns: int) -> None:
    """Stop before a factorization whose analysis says it needs ``factor_bytes`` (factors
    and work space) where less memory is available. The message gives the size of a model
    that would fit: a 3D model's factor grows as the 4/3 power of its size (nested
    dissection), so a model of ``(available / needed)^(3/4)`` of this one would.

    Raises
    ------
    MemoryLimitError
        Unless :data:`IGNORE_LIMIT` is set (then a warning).
    """
    have = available_bytes()
    if have is None or factor_bytes <= have:
        return
    fit = (have / factor_bytes) ** 0.75
    text = (f"the factorization of {unknowns} unknowns needs about "
            f"{format_bytes(factor_bytes)} (from its ordering's fill), more than the "
            f"{format_bytes(have)} available; a model of about {fit:.0%} of this size "
            f"(in elements) would fit")
    if IGNORE_LIMIT.get():
        log.warning("%s; running anyway (--ignore-memory-limit)", text)
        return
    raise MemoryLimitError(f"error: {text}. Reduce the model, free memory, or run anyway "
                           f"with --ignore-memory-limit")
