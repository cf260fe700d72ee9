"""The checksum of a results file's root attributes: which run wrote the file.

The root attributes written with the header (``program_version``, ``created``, the deck's
path, text and SHA-256, the analysis ...) never change afterwards; schema 2.18 stores the
CRC-32 of all of them, in a fixed order and encoding, as the root attribute
``header_crc32`` (int64), so that a changed one is reported as damage like a changed
dataset (docs/results.md, "Integrity"). ``completed``, ``error`` and ``warnings`` are left
out: they are written when the file is closed. A file without ``header_crc32`` (before
2.18) is read as before, its root attributes unchecked.
"""
from __future__ import annotations

import zlib

import numpy as np

#: The root attribute holding the checksum.
HEADER_CRC_ATTR = "header_crc32"
#: The root attributes it covers, in this order (those present).
HEADER_ATTRS = ("filetype", "schema_version", "program", "program_version", "created",
                "deck_path", "deck_sha256", "deck_text", "analysis", "deformations",
                "rotary_inertia")


def _value_bytes(value) -> bytes:
    """A root attribute's value as bytes: a string's UTF-8 (h5py returns str, or bytes for a
    fixed-length string), an array's type and little-endian C-order bytes."""
    if isinstance(value, bytes):
        return b"s" + value
    if isinstance(value, str):
        return b"s" + value.encode("utf-8", errors="surrogatepass")
    a = np.ascontiguousarray(value)
    if a.dtype.kind in "biuf":
        a = a.astype(a.dtype.newbyteorder("<"))
    return f"a{a.dtype.str}{a.shape}".encode() + a.tobytes()


def header_crc(attrs) -> np.int64:
    """CRC-32 of the :data:`HEADER_ATTRS` present in ``attrs`` (a mapping: an h5py
    ``AttributeManager`` or a dict of the values written), each as its name, a NUL, its
    length and its bytes (:func:`_value_bytes`)."""
    crc = 0
    for name in HEADER_ATTRS:
        if name in attrs:
            data = _value_bytes(attrs[name])
            crc = zlib.crc32(name.encode() + b"\0" + str(len(data)).encode() + b"\0" + data,
                             crc)
    return np.int64(crc)


def header_problems(attrs) -> list[str]:
    """One message where ``attrs`` (a file's root attributes) carry a ``header_crc32`` that
    does not match them; none for a file without one (schema 2.14 and older)."""
    stored = attrs.get(HEADER_CRC_ATTR) if HEADER_CRC_ATTR in attrs else None
    if stored is None:
        return []
    try:
        ok = int(np.asarray(stored).reshape(())) == int(header_crc(attrs))
    except (TypeError, ValueError):
        ok = False
    if ok:
        return []
    return ["the root attributes are damaged (program_version, created, the deck's path, "
            "text or SHA-256, the analysis ...: they do not match header_crc32)"]


__all__ = ["HEADER_CRC_ATTR", "HEADER_ATTRS", "header_crc", "header_problems"]
