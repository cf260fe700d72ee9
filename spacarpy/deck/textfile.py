"""Deck files -> text: UTF-8 or latin-1, binary and oversized files refused with a reason."""
from __future__ import annotations

import os

from spacarpy.errors import DeckError

__all__ = ["MAX_DECK_BYTES", "NotADeckError", "read_deck_text", "read_text"]

#: Largest deck file read (a 10^5-element deck is about 10 MB): a bigger file is refused
#: before it fills the memory (``run /dev/urandom``, a log file given by mistake).
MAX_DECK_BYTES = 512 * 2**20
_SNIFF_BYTES = 8192
_HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"


class NotADeckError(OSError):
    """The file is not a text deck (binary data, or larger than :data:`MAX_DECK_BYTES`)."""


def read_text(path) -> str:
    """Read a deck file as text: UTF-8 (a byte-order mark is dropped), else latin-1.

    Binary files are refused from their first bytes (a NUL byte: HDF5 results, /dev/zero,
    executables), files above :data:`MAX_DECK_BYTES` after reading that much, so that no
    input fills the memory or is echoed raw to a terminal.

    Raises
    ------
    OSError
        If the file cannot be read or is not a text deck (:class:`NotADeckError`); the caller
        turns it into a DeckError.
    """
    _refuse_blocking(path)
    with open(path, "rb") as fh:
        head = fh.read(_SNIFF_BYTES)
        if head.startswith(_HDF5_SIGNATURE):
            raise NotADeckError("not a deck but an HDF5 file (a result file?)")
        if _utf16(head):
            raise NotADeckError("not a text deck this reader takes: it is UTF-16 encoded; "
                                "save it as UTF-8 (or ASCII)")
        if b"\0" in head:
            raise NotADeckError("not a text deck: it holds binary data (NUL bytes in its "
                                f"first {len(head)} bytes)")
        raw = head + fh.read(MAX_DECK_BYTES + 1 - len(head)) if len(head) == _SNIFF_BYTES \
            else head
        if len(raw) > MAX_DECK_BYTES:
            raise NotADeckError(f"larger than {MAX_DECK_BYTES // 2**20} MB; not read (a deck "
                                "of 10^5 elements is about 10 MB)")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        text = raw.decode("latin-1")
    return text.removeprefix("\ufeff")


def _os_reason(exc: OSError) -> str:
    if isinstance(exc, NotADeckError):
        return str(exc)
    if isinstance(exc, FileNotFoundError):
        return "no such file"
    if isinstance(exc, IsADirectoryError):
        return "it is a directory"
    return exc.strerror or str(exc)


def read_deck_text(path) -> str:
    """Read a deck file as text (see :func:`read_text`).

    Raises
    ------
    DeckError
        If the file cannot be read.
    """
    try:
        return read_text(path)
    except OSError as exc:
        raise DeckError((None, f"cannot read deck '{path}': {_os_reason(exc)}")) from None


def _refuse_blocking(path) -> None:
    """Refuse a FIFO or a socket before opening it: ``open`` would wait forever for a
    writer (``INCLUDE "fifo"``)."""
    import stat
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return                          # open() reports it
    if stat.S_ISFIFO(mode) or stat.S_ISSOCK(mode):
        kind = "a FIFO (named pipe)" if stat.S_ISFIFO(mode) else "a socket"
        raise NotADeckError(f"not a deck file but {kind}: not opened (reading it could "
                            "wait forever)")


def _utf16(head: bytes) -> bool:
    """UTF-16 text: a byte-order mark, or ASCII with a NUL byte beside every character."""
    if head[:2] in (b"\xff\xfe", b"\xfe\xff"):
        return True
    if len(head) < 4:
        return False
    even, odd = head[0::2], head[1::2]
    return (even.count(0) == len(even) and 0 not in odd) or \
        (odd.count(0) == len(odd) and 0 not in even)
