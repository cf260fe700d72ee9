"""The lines of a large deck scanned at once with numpy: tokens, keywords, numbers.

The parser (:mod:`spacarpy.deck.parser`) reads a deck line by line; for a deck of 2x10^5
lines the Python work per line (splitting it, finding its batch) took a third of the
reading. :class:`LineScan` finds, for all lines of a text at once, the tokens (runs of
characters other than blanks), the first word of each line and the number of tokens, and
which lines are *simple* (only letters, digits, ``_ . + -``, blanks and tabs: no comment,
string, expression or range). The parser appends runs of simple lines to its batches
without looking at them one by one, and converts their numbers here
(:meth:`LineScan.numbers`); every other line it reads as before. For a simple line the
tokens are those of ``str.split()``, so both ways give the same batches
(tests/test_deck_fast.py).
"""
from __future__ import annotations

import numpy as np

__all__ = ["KEY_BYTES", "LineScan"]

#: First words longer than this are not keyed (such lines are read one by one).
KEY_BYTES = 8
#: Digits of a whole number converted with numpy (exact in int64 and in a float).
_MAX_DIGITS = 15

_CLASS = np.zeros(256, dtype=np.uint8)     # 0: other (not simple), 1: blank, 2: token
_CLASS[[ord(" "), ord("\t"), ord("\r"), ord("\n")]] = 1
for _c in "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_.+-":
    _CLASS[ord(_c)] = 2


class LineScan:
    """Tokens and first words of every line of an ASCII text (see the module docstring).

    Attributes
    ----------
    n_tokens : (n_lines,) int
        Tokens of each line (blanks, tabs and carriage returns separate them).
    simple : (n_lines,) bool
        The line has simple characters only and at most KEY_BYTES in its first token.
    combo : (n_lines,) int
        For a simple line with tokens, the index of its (first word, token count) in
        ``combos``; -1 otherwise.
    combos : list of (str, int)
        The distinct (first word, number of tokens) of the simple lines.
    """

    def __init__(self, text: str):
        b = np.frombuffer(text.encode("ascii"), dtype=np.uint8)
        self.text, self.bytes = text, b
        self._nondigit = None
        newline = np.flatnonzero(b == 10)
        starts = np.concatenate([[0], newline + 1])
        ends = np.concatenate([newline, [len(b)]])
        n_lines = len(starts)
        cls = _CLASS[b]
        # a line is simple when it holds no byte of class 0 (those are few: find them)
        simple = np.ones(n_lines, dtype=bool)
        simple[np.searchsorted(starts, np.flatnonzero(cls == 0), side="right") - 1] = False
        edge = np.diff((cls == 2).view(np.int8), prepend=np.int8(0), append=np.int8(0))
        self.tok_start = np.flatnonzero(edge == 1)
        self.tok_end = np.flatnonzero(edge == -1)
        self.first_tok = np.searchsorted(self.tok_start, starts)
        self.n_tokens = np.searchsorted(self.tok_start, ends) - self.first_tok
        has = self.n_tokens > 0
        first = np.minimum(self.first_tok, max(len(self.tok_start) - 1, 0))
        length = np.where(has, (self.tok_end[first] - self.tok_start[first])
                          if len(self.tok_start) else 0, 0)
        simple &= length <= KEY_BYTES
        self.simple = simple
        self.combo = np.full(n_lines, -1, dtype=np.int64)
        self.combos: list = []
        keyed = np.flatnonzero(simple & has)
        if len(keyed):
            at = self.tok_start[self.first_tok[keyed]][:, None] + np.arange(KEY_BYTES)
            inside = np.arange(KEY_BYTES) < length[keyed][:, None]
            word = np.where(inside, b[np.minimum(at, len(b) - 1)], 0).astype(np.uint8)
            key = np.ascontiguousarray(word).view(np.uint64).ravel()
            count = self.n_tokens[keyed]
            # the lines of a deck come in runs of one keyword: look at the first of each run
            head = np.flatnonzero(np.concatenate([[True], (key[1:] != key[:-1]) |
                                                  (count[1:] != count[:-1])]))
            pairs: dict = {}
            run_combo = [pairs.setdefault(pair, len(pairs)) for pair in
                         zip(key[head].tolist(), count[head].tolist())]
            self.combo[keyed] = np.repeat(run_combo, np.diff(head, append=len(keyed)))
            self.combos = [(np.array([k], dtype=np.uint64).view(np.uint8).tobytes()
                            .rstrip(b"\0").decode(), n) for k, n in pairs]

    def numbers(self, tokens: np.ndarray):
        """The numbers of some tokens (an int array of token indices, any shape):
        ``(values, texts_ok, texts)``. A token of digits only (at most 15) is converted here;
        the others are returned as ``texts`` (a list of str, in the order of
        ``np.flatnonzero(~digits)``) for the caller to convert, with their values 0 and
        ``texts_ok`` False there."""
        flat = tokens.ravel()
        s, e = self.tok_start[flat], self.tok_end[flat]
        b = self.bytes
        if self._nondigit is None:
            self._nondigit = np.concatenate([[0], np.cumsum((b < 48) | (b > 57),
                                                            dtype=np.int32)])
        nondigit = self._nondigit
        length = e - s
        digits = (nondigit[e] == nondigit[s]) & (length <= _MAX_DIGITS)
        values = np.zeros(len(flat))
        d = np.flatnonzero(digits)
        if len(d):
            ds, dl = s[d], length[d]
            for n in np.unique(dl).tolist():        # the tokens of n digits together
                mine = dl == n
                at = ds[mine]
                value = b[at].astype(np.int64) - 48
                for k in range(1, n):
                    value = value * 10 + (b[at + k].astype(np.int64) - 48)
                values[d[mine]] = value
        text = self.text
        texts = [text[i:j] for i, j in zip(s[~digits].tolist(), e[~digits].tolist())]
        return values.reshape(tokens.shape), digits.reshape(tokens.shape), texts
