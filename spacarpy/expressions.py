"""Arithmetic in deck fields (spacarpy extension): parse ``{...}`` expressions and evaluate them.

An expression field is written in braces, ``{R*sin(pi/4)}``, so that it can never be mistaken
for several blank-separated fields. The grammar is ``expr.lark``; the evaluation walks the
Lark parse tree with a fixed table of operators and functions (Python's ``eval`` is never
used), so a deck cannot run code. All arithmetic is in double precision; the result of every
operation must be finite.

Errors are :class:`ExpressionError` with a 0-based offset into the expression text, which the
deck parser turns into a file:line:column message.
"""
from __future__ import annotations

import difflib
import math
from collections.abc import Mapping
from functools import lru_cache
from pathlib import Path

from lark import Token, Tree
from lark.exceptions import UnexpectedCharacters, UnexpectedEOF, UnexpectedInput, UnexpectedToken

from spacarpy.grammars import lalr_parser

__all__ = ["CONSTANTS", "FUNCTIONS", "RESERVED_NAMES", "ExpressionError", "evaluate",
           "parse_expression", "whole_number"]

#: Functions available in expressions: name -> (number of arguments, implementation, usage).
FUNCTIONS: dict[str, tuple[int, object, str]] = {
    "sqrt": (1, math.sqrt, "sqrt(x)"),
    "sin": (1, math.sin, "sin(x), x in radians"),
    "cos": (1, math.cos, "cos(x), x in radians"),
    "tan": (1, math.tan, "tan(x), x in radians"),
    "asin": (1, math.asin, "asin(x), in radians"),
    "acos": (1, math.acos, "acos(x), in radians"),
    "atan": (1, math.atan, "atan(x), in radians"),
    "atan2": (2, math.atan2, "atan2(y, x), in radians"),
    "exp": (1, math.exp, "exp(x)"),
    "log": (1, math.log, "log(x), natural logarithm"),
    "log10": (1, math.log10, "log10(x)"),
    "abs": (1, abs, "abs(x)"),
}

#: Named constants available in expressions.
CONSTANTS: dict[str, float] = {"pi": math.pi}

#: Names a SET may not use.
RESERVED_NAMES = frozenset(FUNCTIONS) | frozenset(CONSTANTS)

_PARSER = lalr_parser(Path(__file__).with_name("expr.lark"), propagate_positions=True,
                      maybe_placeholders=False)


class ExpressionError(Exception):
    """A problem in an expression.

    Attributes
    ----------
    offset : int
        0-based position in the expression text where the problem is.
    message : str
        What is wrong, in user words.
    unknown_name : str or None
        The name, when the problem is an unknown parameter.
    """

    def __init__(self, offset: int, message: str, unknown_name: str | None = None):
        super().__init__(message)
        self.offset = max(int(offset), 0)
        self.message = message
        self.unknown_name = unknown_name


def _expected_words(expected) -> str:
    """What the parser wanted, in user words."""
    if {"NUMBER", "NAME", "LPAR"} & set(expected):
        return "a number, a parameter name or '('"
    words = ["an operator (+ - * / ^)"]
    if "RPAR" in expected:
        words.append("')'")
    if "COMMA" in expected:
        words.append("','")
    return ", ".join(words[:-1]) + (" or " if len(words) > 1 else "") + words[-1]


@lru_cache(maxsize=4096)
def parse_expression(text: str) -> Tree | Token:
    """Parse the text between the braces of an expression field.

    Parameters
    ----------
    text : str
        For example ``"R*sin(pi/4)"``.

    Returns
    -------
    lark.Tree or lark.Token
        The parse tree (cached by text).

    Raises
    ------
    ExpressionError
        With the offset of the first character that does not fit.
    """
    if not text.strip():
        raise ExpressionError(0, "empty expression: write a number or a formula between the "
                                 "braces, e.g. {2*pi/8}")
    try:
        return _PARSER.parse(text)
    except UnexpectedCharacters as exc:
        ch = text[exc.pos_in_stream] if exc.pos_in_stream < len(text) else ""
        hint = " (',' separates function arguments; blanks are allowed)" if ch == ";" else ""
        raise ExpressionError(exc.pos_in_stream,
                              f"unexpected character '{ch}' in the expression{hint}") from None
    except UnexpectedToken as exc:
        tok = exc.token
        expected = set(exc.accepts or exc.expected)
        if tok.type == "$END":
            if "RPAR" in expected and not {"NUMBER", "NAME", "LPAR"} & expected:
                raise ExpressionError(len(text.rstrip()), "a ')' is missing at the end of the "
                                                          "expression") from None
            raise ExpressionError(len(text.rstrip()), "the expression ends too early: expected "
                                                      f"{_expected_words(expected)}") from None
        before = text[:tok.start_pos]
        if tok.type == "RPAR" and before.count("(") <= before.count(")"):
            raise ExpressionError(tok.start_pos, "unbalanced ')': there is no '(' to close") \
                from None
        raise ExpressionError(tok.start_pos, f"expected {_expected_words(expected)} before "
                                             f"'{tok}' in the expression") from None
    except UnexpectedEOF:  # pragma: no cover - LALR reports end of input as UnexpectedToken
        raise ExpressionError(len(text), "the expression ends too early") from None
    except UnexpectedInput:  # pragma: no cover - no other lark error exists for LALR
        raise ExpressionError(0, "cannot read the expression") from None


def _offset(node) -> int:
    if isinstance(node, Token):
        return node.start_pos or 0
    meta = node.meta
    return 0 if getattr(meta, "empty", True) else meta.start_pos


def _finite(value: float, node) -> float:
    if not math.isfinite(value):
        raise ExpressionError(_offset(node), "the result is too large (not a finite number)")
    return value


def _suggest(name: str, candidates) -> str:
    lower = {c.lower(): c for c in candidates}
    if name.lower() in lower:
        return f" (did you mean {lower[name.lower()]}? names are case-sensitive)"
    close = difflib.get_close_matches(name, list(candidates), n=1, cutoff=0.6)
    return f" (did you mean {close[0]}?)" if close else ""


class _Evaluator:
    def __init__(self, params: Mapping[str, float]):
        self.params = params

    def value(self, node) -> float:
        if isinstance(node, Token):            # a bare NUMBER or NAME (tree of one token)
            return self.token(node)
        op = node.data
        ch = node.children
        if op == "number" or op == "name":
            return self.token(ch[0])
        if op == "neg":
            return -self.value(ch[0])
        if op == "pos":
            return self.value(ch[0])
        if op == "call":
            return self.call(node)
        a = self.value(ch[0])
        b = self.value(ch[-1])
        try:
            if op == "add":
                return _finite(a + b, node)
            if op == "sub":
                return _finite(a - b, node)
            if op == "mul":
                return _finite(a * b, node)
            if op == "div":
                if b == 0:
                    raise ExpressionError(_offset(ch[-1]), "division by zero")
                return _finite(a / b, node)
            if op == "pow":
                if a < 0 and not float(b).is_integer():
                    raise ExpressionError(_offset(node), f"cannot raise the negative number "
                                                         f"{a:g} to the power {b:g}")
                if a == 0 and b < 0:
                    raise ExpressionError(_offset(node), "division by zero (0 to a negative "
                                                         "power)")
                return _finite(math.pow(a, b), node)
        except OverflowError:
            raise ExpressionError(_offset(node), "the result is too large (not a finite "
                                                 "number)") from None
        raise ExpressionError(_offset(node), f"unknown operation '{op}'")  # pragma: no cover

    def token(self, tok: Token) -> float:
        if tok.type == "NUMBER":
            value = float(str(tok).replace("d", "e").replace("D", "e"))
            if not math.isfinite(value):
                raise ExpressionError(tok.start_pos, f"the number '{tok}' is out of range")
            return value
        name = str(tok)
        if name in self.params:
            return float(self.params[name])
        if name in CONSTANTS:
            return CONSTANTS[name]
        if name in FUNCTIONS:
            raise ExpressionError(tok.start_pos, f"'{name}' is a function: write "
                                                 f"{FUNCTIONS[name][2].split(',')[0]}")
        known = list(self.params) + list(CONSTANTS)
        msg = f"unknown parameter '{name}'{_suggest(name, known)}"
        if not self.params:
            msg += "; define it first with SET name value"
        raise ExpressionError(tok.start_pos, msg, unknown_name=name)

    def call(self, node: Tree) -> float:
        name_tok, *args = node.children
        name = str(name_tok)
        spec = FUNCTIONS.get(name)
        if spec is None:
            if name in self.params or name in CONSTANTS:
                raise ExpressionError(name_tok.start_pos, f"'{name}' is a parameter, not a "
                                                          "function")
            raise ExpressionError(name_tok.start_pos,
                                  f"unknown function '{name}'{_suggest(name, FUNCTIONS)} "
                                  f"(functions: {', '.join(FUNCTIONS)})")
        n_args, func, usage = spec
        if len(args) != n_args:
            raise ExpressionError(name_tok.start_pos,
                                  f"{name} takes {n_args} argument{'s' if n_args > 1 else ''} "
                                  f"({usage}), got {len(args)}")
        values = [self.value(a) for a in args]
        try:
            return _finite(float(func(*values)), node)
        except (ValueError, OverflowError):
            shown = ", ".join(f"{v:g}" for v in values)
            raise ExpressionError(name_tok.start_pos,
                                  f"cannot evaluate {name}({shown}): outside its domain or "
                                  "too large") from None


def evaluate(text: str, params: Mapping[str, float] | None = None) -> float:
    """Evaluate an expression.

    Parameters
    ----------
    text : str
        The text between the braces, e.g. ``"R*(1-cos(pi/4))"``.
    params : mapping of str to float, optional
        The parameters defined so far (by SET lines).

    Returns
    -------
    float
        A finite number.

    Raises
    ------
    ExpressionError
        If the text is not an expression, uses an unknown name, or cannot be evaluated
        (division by zero, a function outside its domain, overflow).
    """
    tree = parse_expression(text)
    try:
        return _Evaluator(params or {}).value(tree)
    except RecursionError:
        raise ExpressionError(0, "the expression is nested too deeply") from None


def whole_number(value: float, rtol: float = 1e-9) -> int | None:
    """``value`` as an int if it is a whole number (to ``rtol``), else None.

    Expressions in node and element fields are evaluated in floating point; ``{0.1*30}`` is
    3.0000000000000004 and still means 3.
    """
    if not math.isfinite(value):
        return None
    nearest = round(value)
    if abs(value - nearest) <= rtol * max(1.0, abs(value)):
        return int(nearest)
    return None
