"""Which of the HDF5 libraries in the process is h5py's own (netCDF4's wheel brings another):
the one whose functions spacarpy may call on h5py's property lists."""
from __future__ import annotations

import functools
import os

import h5py

__all__ = ["h5py_hdf5_library"]


@functools.cache
def h5py_hdf5_library():
    """``(path, H5Pset_metadata_read_attempts)`` of the HDF5 library h5py itself uses, or
    None.

    A process may hold several HDF5 libraries (netCDF4's wheel brings its own): a property
    set through another library's function does nothing to h5py's file access list, and an
    SWMR reader then retries a failing checksum for minutes. The libraries in h5py's own
    folders are tried first, and a library is taken only when it reads back a property that
    h5py set on its own list (the sieve buffer size): the same library, not just one with
    the same name."""
    import ctypes
    names = []
    try:
        with open("/proc/self/maps", encoding="ascii", errors="replace") as maps:
            names = [line.split()[-1] for line in maps if "/libhdf5" in line]
    except OSError:
        pass
    names = [n for n in dict.fromkeys(names) if not os.path.basename(n).startswith("libhdf5_")]
    own = os.path.dirname(os.path.abspath(h5py.__file__))
    names.sort(key=lambda n: not n.startswith((own + os.sep, own + ".libs" + os.sep)))
    probe = h5py.h5p.create(h5py.h5p.FILE_ACCESS)
    marker = 54321
    probe.set_sieve_buf_size(marker)
    for name in names:
        try:
            lib = ctypes.CDLL(name)
            fn, get = lib.H5Pset_metadata_read_attempts, lib.H5Pget_sieve_buf_size
        except (OSError, AttributeError):
            continue
        get.argtypes, get.restype = [ctypes.c_int64, ctypes.POINTER(ctypes.c_size_t)], ctypes.c_int
        size = ctypes.c_size_t(0)
        if get(probe.id, ctypes.byref(size)) < 0 or size.value != marker:
            continue                 # another HDF5 library in the process: not h5py's
        fn.argtypes, fn.restype = [ctypes.c_int64, ctypes.c_uint], ctypes.c_int
        return name, fn
    return None
