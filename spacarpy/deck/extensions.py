"""The spacarpy extensions that act on the deck text: ``SET`` parameters (and their ``--set``
overrides), ``{expression}`` fields, ``1:48`` ranges and ``INCLUDE "file"`` (:class:`_Extensions`,
a part of the parser's reader)."""
from __future__ import annotations

import math
import os
import re
from pathlib import Path
from typing import TYPE_CHECKING

from spacarpy.deck.keywords import (
    FieldSpec,
)

if TYPE_CHECKING:                      # Lark is imported only when a line needs it
    from lark import Token
from spacarpy.deck.fields import (
    _INT_LIMIT,
    _expr,
    _FieldError,
)
from spacarpy.deck.lexer import (
    _Record,
)
from spacarpy.deck.textfile import (
    _os_reason,
    read_text,
)

__all__ = ["MAX_RANGE"]

#: Most numbers a single range (``1:48``) may stand for.
MAX_RANGE = 1_000_000
#: Deepest chain of INCLUDEs (cycles are reported before this is reached).
_MAX_INCLUDE_DEPTH = 32

_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_RANGE_PART = re.compile(r"\{[^}]*\}|\d+")


class _Extensions:
    """SET, INCLUDE, expressions and ranges of :class:`spacarpy.deck.parser._Reader`."""

    def include(self, rec: _Record, st_fields: tuple) -> None:
        name = st_fields[0]
        src = rec.source
        loc = self.loc(rec, rec.fields[0])
        base = src.path.parent if src.path is not None else Path(os.path.dirname(src.name))
        target = base / name
        shown = os.path.normpath(os.path.join(os.path.dirname(src.name), name)) \
            if src.path is not None else name
        try:
            resolved = target.resolve()
        except (OSError, RuntimeError):       # pragma: no cover - resolution loops
            resolved = target
        if resolved in self.stack:
            chain = " -> ".join(p.name for p in self.stack[self.stack.index(resolved):])
            self.error(loc, f"INCLUDE cycle: {chain} -> {resolved.name} (a file may not "
                            "include itself, directly or indirectly)", src)
            return
        if len(self.stack) >= _MAX_INCLUDE_DEPTH:
            self.error(loc, f"INCLUDE: files nested more than {_MAX_INCLUDE_DEPTH} deep", src)
            return
        if resolved in self.included:
            first = self.included[resolved]
            self.error(loc, f"INCLUDE '{name}': {shown} is already included (at {first}); "
                            "a file included twice would define its nodes, elements and "
                            "loads twice", src)
            return
        self.included[resolved] = loc
        try:
            text = read_text(target)
        except OSError as exc:
            self.error(loc, f"INCLUDE: cannot read '{name}' (looked for {target}): "
                            f"{_os_reason(exc)}", src)
            return
        self.read(text, shown, target)

    def set_parameter(self, rec: _Record, converted: tuple) -> bool:
        """Define a parameter (or apply its --set override); False after an error."""
        (name, value), locs = converted
        loc = locs[0]
        if not _NAME.fullmatch(name):
            self.error(loc, f"SET: '{name}' is not a valid parameter name (letters, digits and "
                            "'_', starting with a letter)", rec.source)
            return False
        if name in _expr().RESERVED_NAMES:
            self.error(loc, f"SET: '{name}' is a built-in name and cannot be set", rec.source)
            return False
        if name in self.params:
            first = self.param_locs[name]
            where = f"line {first.line}" if first.file == loc.file else f"{first}"
            self.error(loc, f"SET: parameter '{name}' is already set ({where}); a parameter is "
                            "set once", rec.source)
            return False
        if name in self.overrides:
            self.overrides_used.add(name)
            override = self.overrides[name]
            try:
                if isinstance(override, (int, float)) and not isinstance(override, bool):
                    value = float(override)
                    if not math.isfinite(value):
                        raise _expr().ExpressionError(0, "not a finite number")
                else:
                    text = str(override).strip()
                    if text.startswith("{") and text.endswith("}"):
                        text = text[1:-1]
                    value = _expr().evaluate(text, self.params)
            except _expr().ExpressionError as exc:
                # reported; the deck's own value is kept so that later lines are still checked
                self.error(None, f"--set {name}={override}: {exc.message}")
        self.params[name] = value
        self.param_locs[name] = loc
        return True

    def expression(self, tok: Token, index: int, text: str | None = None,
                   offset: int = 0) -> float:
        """Evaluate an {expression} field (or the part ``text`` of a range at ``offset``)."""
        text = str(tok)[1:-1] if text is None else text
        try:
            return _expr().evaluate(text, self.params)
        except _expr().ExpressionError as exc:
            if exc.unknown_name is not None:
                self.unknown_uses.append((len(self.errors), exc.unknown_name))
            raise _FieldError(index, exc.message, offset + 1 + exc.offset) from None

    def range_values(self, tok: Token, spec: FieldSpec, keyword: str, index: int) -> range:
        """The numbers of a range field ``first:last`` or ``first:step:last``."""
        parts = _RANGE_PART.findall(str(tok))
        numbers = []
        offset = 0
        for part in parts:
            offset = str(tok).index(part, offset)
            if part.startswith("{"):
                value = self.expression(tok, index, part[1:-1], offset)
                ivalue = _expr().whole_number(value)
                if ivalue is None:
                    raise _FieldError(index, f"{keyword}: the range '{tok}' needs whole "
                                             f"numbers, but {part} = {value:.10g}", offset)
            else:
                ivalue = int(part)
            numbers.append(ivalue)
            offset += len(part)
        if len(numbers) == 3:
            first, step, last = numbers
        else:
            (first, last), step = numbers, 1
        if step < 1:
            raise _FieldError(index, f"{keyword}: the step of the range '{tok}' must be at least "
                                     "1 (first:step:last)")
        if last < first:
            raise _FieldError(index, f"{keyword}: the range '{tok}' is empty: it must count "
                                     f"upwards (first {first} > last {last})")
        if spec.positive and first < 1:
            raise _FieldError(index, f"{keyword}: the range '{tok}' must start at 1 or more")
        if max(abs(first), abs(last)) > _INT_LIMIT:
            raise _FieldError(index, f"{keyword}: the range '{tok}' is out of range")
        values = range(first, last + 1, step)
        if len(values) > MAX_RANGE:
            raise _FieldError(index, f"{keyword}: the range '{tok}' has {len(values)} numbers; "
                                     f"at most {MAX_RANGE} are allowed")
        return values
