"""Print, and check, the number of threads numpy's and scipy's BLAS really use.

Usage: ``python .ci/blas_threads.py N`` exits 1 when a BLAS library it can query reports
another count than N (an environment variable set too late or spelt wrong would make the
"two threads" pass of .ci/run silently run one). Uses threadpoolctl when installed, else
asks the OpenBLAS libraries the process has loaded through their C API.
"""
import ctypes
import sys

import numpy as np
import scipy.linalg  # noqa: F401  (loads scipy's own BLAS, if it has one)


def counts() -> dict:
    try:
        from threadpoolctl import threadpool_info
    except ImportError:
        pass
    else:
        return {i["filepath"]: i["num_threads"] for i in threadpool_info()
                if i.get("user_api") == "blas"}
    out = {}
    with open("/proc/self/maps") as maps:
        paths = sorted({line.split()[-1] for line in maps if "openblas" in line.lower()})
    for path in paths:
        lib = ctypes.CDLL(path)
        for name in ("scipy_openblas_get_num_threads64_", "scipy_openblas_get_num_threads",
                     "openblas_get_num_threads64_", "openblas_get_num_threads"):
            if hasattr(lib, name):
                out[path] = int(getattr(lib, name)())
                break
    return out


def main() -> int:
    want = int(sys.argv[1])
    found = counts()
    print(f"numpy {np.__version__}: BLAS threads {found or 'unknown (no OpenBLAS found)'}")
    bad = {p: n for p, n in found.items() if n != want}
    if bad:
        print(f"expected {want} BLAS thread(s), got {bad}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
