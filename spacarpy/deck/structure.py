"""Module tracking: which SPACAR module or section a record is in (END, HALT, END END, the
VISUALIZATION section), the records that cannot be anywhere (unknown keywords, text after the
final END), and the checks at the deck's end (:class:`_ModuleStructure`, a part of the
parser's reader)."""
from __future__ import annotations

import difflib
import logging
import re
from typing import TYPE_CHECKING

from spacarpy.deck.keywords import (
    KEYWORDS,
    VISUALIZATION_KEYWORDS,
)
from spacarpy.errors import SourceLoc

if TYPE_CHECKING:                      # Lark is imported only when a line needs it
    pass
from spacarpy.deck.fields import (
    _field_specs,
    _FieldError,
)
from spacarpy.deck.lexer import (
    _bad_token_message,
    _Record,
)

logger = logging.getLogger(__name__)

_GLUED = re.compile(r"([A-Z]+)([+-]?\d[\d.eE+-]*)")


class _ModuleStructure:
    """The module structure of :class:`spacarpy.deck.parser._Reader`."""

    def finish(self) -> None:
        """Checks at the end of the deck: a missing END, unused --set overrides."""
        if self.any_end and not (self.prev_end or self.closed) and self.last is not None \
                and not self.visual and not self.structure_error:
            rec = self.last_record()
            end = (rec.fields or (rec.head,))[-1]
            loc = SourceLoc(rec.source.name, end.line, end.end_column)
            start = (f" (the last module starts at line {self.module_start.line})"
                     if self.module_start is not None else "")
            self.order += 1
            self.error(loc, "missing END at the end of the deck: close the last module with "
                            f"END, and the deck with END END{start}", rec.source)
        for i, name in self.unknown_uses:
            if name in self.param_locs and i < len(self.errors):
                key, loc, msg, src = self.errors[i]
                where = self.param_locs[name]
                msg = msg.removesuffix("; define it first with SET name value")
                msg += (f" (it is SET at line {where.line}" if where.file == loc.file
                        else f" (it is SET at {where}") + ", after its use: move the SET up)"
                self.errors[i] = (key, loc, msg, src)
        unused = [k for k in self.overrides if k not in self.overrides_used]
        for name in unused:
            known = ", ".join(self.params) if self.params else "none: the deck has no SET lines"
            self.error(None, f"--set {name}: the deck has no 'SET {name}' line to override "
                             f"(its parameters: {known})")

    def record(self, rec: _Record) -> None:
        head = rec.head
        if head.type != "WORD":
            self.not_a_keyword(rec)
            self.prev_end = False
            return
        keyword = str(head).upper()
        if keyword in ("INCLUDE", "SET"):
            if self.closed and not self.visual:
                self.after_final_end(rec)
                return
            converted = self.check_fields(rec, keyword, KEYWORDS[keyword])
            if converted is not None:
                if keyword == "INCLUDE":
                    self.include(rec, converted[0][0])
                elif self.set_parameter(rec, converted[0]):
                    name, value = converted[0][0][0], self.params[converted[0][0][0]]
                    self.emit(rec, keyword, [((name, value), converted[0][1])],
                              -1 if self.visual else self.module)
            self.last = (rec.source, rec.head.line)
            return
        if self.visual or keyword == "VISUALIZATION":
            self.visualization(rec, keyword)
            return
        if self.closed:
            self.after_final_end(rec)
            return
        spec = KEYWORDS.get(keyword)
        if spec is None:
            self.unknown_keyword(rec, keyword)
            self.prev_end = False
            self.last = (rec.source, rec.head.line)
            return
        if spec.data_form is not None and self.module >= 1:
            spec = spec.data_form
        converted = self.check_fields(rec, keyword, spec)
        if keyword == "END":
            if self.prev_end:
                self.closed = True
                this_module = self.module - 1
            else:
                this_module = self.module
                self.module += 1
            self.prev_end = True
            self.any_end = True
        else:
            if keyword == "HALT":
                self.any_end = True
                if not self.prev_end:
                    self.structure_error = True
                    self.error(self.loc(rec, head), "missing END before HALT: HALT must directly "
                                                    "follow the END that closes a module",
                               rec.source)
                else:
                    self.module_start = self.loc(rec, head)
            this_module = self.module
            self.prev_end = False
        self.last = (rec.source, rec.head.line)
        if converted is not None:
            self.emit(rec, keyword, converted, this_module)

    def visualization(self, rec: _Record, keyword: str) -> None:
        if not self.visual:
            if not (self.prev_end or self.closed):
                self.structure_error = True
                self.error(self.loc(rec, rec.head),
                           "missing END before VISUALIZATION: the VISUALIZATION section comes "
                           "after the final END END", rec.source)
            self.visual = True
        spec = VISUALIZATION_KEYWORDS.get(keyword) if keyword != "VISUALIZATION" \
            else KEYWORDS["VISUALIZATION"]
        if spec is None:
            if keyword in KEYWORDS:
                self.error(self.loc(rec, rec.head),
                           f"'{rec.head}' is not a VISUALIZATION keyword: SPACAR lines must come "
                           "before the final END END (SPACAR stops reading there)", rec.source)
                return
            close = difflib.get_close_matches(keyword, list(VISUALIZATION_KEYWORDS), n=1,
                                              cutoff=0.6)
            logger.warning("%s: unknown VISUALIZATION keyword '%s' is ignored%s",
                           self.loc(rec, rec.head), rec.head,
                           f" (did you mean {close[0]}?)" if close else "")
            fields = []
            for tok in rec.fields:
                try:
                    fields.append(self.as_written(tok))
                except _FieldError:
                    fields.append(str(tok))
            self.emit(rec, keyword, [(tuple(fields), tuple(self.loc(rec, t) for t in rec.fields))],
                      -1)
            return
        converted = self.check_fields(rec, keyword, spec)
        if converted is not None:
            self.emit(rec, keyword, converted, -1)

    def after_final_end(self, rec: _Record) -> None:
        self.error(self.loc(rec, rec.head),
                   f"text after the final END: '{rec.head}' (SPACAR stops reading at END END; "
                   "only a VISUALIZATION section may follow)", rec.source)
        self.stopped = True

    def not_a_keyword(self, rec: _Record) -> None:
        head = rec.head
        loc = self.loc(rec, head)
        if head.type == "BAD":
            self.error(loc, _bad_token_message(head), rec.source)
            return
        what = {"NUMBER": "the number", "EXPR": "the expression", "RANGE": "the range",
                "STRING": "the string"}.get(head.type, "")
        msg = f"expected a keyword at the start of the line, found {what} '{head}'"
        prev = self.last_record()
        n_here = 1 + len(rec.fields)
        if prev is not None and prev.source is rec.source and prev.head.type == "WORD":
            spec = KEYWORDS.get(str(prev.head).upper())
            if spec is not None and _field_specs(spec, len(prev.fields) + n_here) is not None \
                    and _field_specs(spec, len(prev.fields)) is None:
                msg += (f" (is this the rest of the {spec.name} record on line {prev.head.line}? "
                        "a record must be on one line)")
                self.error(loc, msg, rec.source)
                return
        msg += " (every line starts with a keyword such as X, BEAM or FIX)"
        self.error(loc, msg, rec.source)

    def unknown_keyword(self, rec: _Record, keyword: str) -> None:
        tok = rec.head
        glued = _GLUED.fullmatch(keyword)
        if keyword in VISUALIZATION_KEYWORDS:
            msg = (f"'{tok}' belongs to the VISUALIZATION section, which comes after the final "
                   "END END")
        elif glued and glued.group(1) in KEYWORDS:
            msg = (f"unknown keyword '{tok}': put a blank between the keyword and the number "
                   f"('{tok[:len(glued.group(1))]} {tok[len(glued.group(1)):]}')")
        else:
            msg = f"unknown keyword '{tok}'"
            close = difflib.get_close_matches(keyword, list(KEYWORDS), n=1, cutoff=0.6)
            if close:
                msg += f" (did you mean {close[0]}?)"
        self.error(self.loc(rec, tok), msg, rec.source)
