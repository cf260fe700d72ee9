"""Process-wide memory allocator setting for large models (glibc only).

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
import ctypes.util
import os

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
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        mallopt = libc.mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes, mallopt.restype = [ctypes.c_int, ctypes.c_int], ctypes.c_int
    ok = (mallopt(_M_MMAP_MAX, 0) == 1                     # no mmap: all from the heap
          and mallopt(_M_TRIM_THRESHOLD, 2**31 - 1) == 1   # never trim the heap's top
          and mallopt(_M_TOP_PAD, 256 * 2**20) == 1)       # grow it in 256 MB steps
    _done = ok
    return ok
