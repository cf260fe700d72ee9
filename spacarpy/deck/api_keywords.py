"""The keyword methods of :class:`~spacarpy.deck.api.ModelBuilder`, made from the keyword table.

One method per deck keyword, named after the keyword in lower case (``hinge``, ``rbeam``,
``plbeam``, ``estiff``, ``gravity``, ``timestep``, ...), made from its
:class:`~spacarpy.deck.keywords.KeywordSpec`: the required fields are positional parameters,
each optional field a parameter that defaults to ``None`` (left out of the line), a vector
group (an element's initial local y-axis, a hinge axis, an arc centre) one tuple parameter,
and a variadic tail ``*values``. Each method has a real :class:`inspect.Signature` and a
docstring with the deck usage line and every field's meaning and unit, and checks its
arguments with the deck's own field specs (whole numbers, positive node and element
numbers, choices, ranges) before it records the line: an error names the method, the
argument and the script line of the call. This module's one job is making those methods;
:mod:`spacarpy.deck.api` holds the builder.
"""
from __future__ import annotations

import inspect
import keyword as _pykeyword
import math
import numbers
from collections.abc import Iterable

from spacarpy.deck.keywords import KEYWORDS, KIND_DESCRIPTIONS, FieldSpec, KeywordSpec

__all__ = ["KEYWORD_METHODS", "PART_OF", "keyword_method", "check_field"]

#: Keywords with no method: the module structure, which the builder writes itself, files
#: (INCLUDE: a script has Python), EXPECT (a check of a deck's run, not part of a model) and
#: the SPACAR keywords spacarpy does not implement.
_NO_METHOD = {"END", "HALT", "VISUALIZATION", "INCLUDE", "EXPECT"}

#: Where a keyword's line goes: "head" (settings, before the kinematics), "kinematics" (the
#: first module), "data" (the second) or "output" (the third: the state-space signals).
_EXTENSION_PART = {"INPUTR": "kinematics", "DELINPR": "data", "LOADTF": "data",
                   "BEAMS": "kinematics", "BEAMARC": "kinematics"}


def _part(spec: KeywordSpec) -> str:
    if spec.name in _EXTENSION_PART:
        return _EXTENSION_PART[spec.name]
    if spec.name == "OUTLEVEL":
        return "data"
    return {"kinematics": "kinematics", "element": "kinematics", "data": "data",
            "output": "output"}.get(spec.section, "head")


#: The part of the deck each keyword's line goes to.
PART_OF = {name: _part(spec) for name, spec in KEYWORDS.items()}

#: The tuple parameter standing for a vector group, by the short name of its first field.
_VECTOR_NAMES = {"ox": "orientation", "ax": "axis", "cx": "center"}


def _is_expression(value) -> bool:
    return isinstance(value, str) and value.strip().startswith("{")


def check_field(method: str, arg: str, field: FieldSpec, value):
    """``value`` checked against ``field`` (its kind, ``positive``, choices and range) and
    returned as the deck should hold it (an integral float of a whole-number field as an
    int); an ``{expression}`` string passes unchecked (the deck reader evaluates it).

    Raises
    ------
    ValueError
        ``ModelBuilder.hinge(): e (element number) must be a whole number, got 2.5``.
    """
    where = f"ModelBuilder.{method}(): {arg} ({field.name})"
    if _is_expression(value):
        return value
    kind = field.kind
    if kind in ("int", "float"):
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            raise ValueError(f"{where} must be {KIND_DESCRIPTIONS[kind]}, got {value!r}")
        if not math.isfinite(float(value)):
            raise ValueError(f"{where} must be a finite number, got {value!r}")
        if kind == "int":
            if float(value) != int(value):
                raise ValueError(f"{where} must be a whole number, got {value!r}")
            value = int(value)
        if field.positive and value < 1:
            raise ValueError(f"{where} must be 1 or more, got {value!r}")
    elif kind == "word" and not isinstance(value, str):
        raise ValueError(f"{where} must be a word (a string), got {value!r}")
    elif kind == "value" and (isinstance(value, bool)
                              or not isinstance(value, (str, numbers.Real))):
        raise ValueError(f"{where} must be a number or a word, got {value!r}")
    if (field.choices is not None or field.min is not None or field.max is not None) \
            and not field.accepts(value):
        allowed = (", ".join(field.choices) if field.choices is not None
                   else field.range_text)
        raise ValueError(f"{where} must be one of {allowed}, got {value!r}"
                         if field.choices is not None else
                         f"{where} must be in {allowed}, got {value!r}")
    return value


def _selection(method: str, arg: str, field: FieldSpec, value) -> list:
    """An element selection (a number, a range, a list) checked entry by entry."""
    if isinstance(value, Iterable) and not isinstance(value, (str, bytes)):
        items = list(value)
        if not items:
            raise ValueError(f"ModelBuilder.{method}(): {arg} ({field.name}) selects no "
                             "element")
        for v in items:
            check_field(method, arg, field, v)
        return items if not isinstance(value, range) else value
    return check_field(method, arg, field, value)


class _Param:
    """One Python parameter: the fields it stands for and how."""

    def __init__(self, name: str, fields: tuple, how: str):
        self.name, self.fields, self.how = name, fields, how    # how: req, opt, vec, var


def _params(spec: KeywordSpec) -> list[_Param]:
    out, used = [], set()

    def name_of(short: str) -> str:
        name = "".join(c if c.isalnum() or c == "_" else "_" for c in short).strip("_") or "v"
        if _pykeyword.iskeyword(name) or name == "self":
            name += "_"
        while name in used:
            name += "_"
        used.add(name)
        return name

    for f in spec.required:
        out.append(_Param(name_of(f.short), (f,), "req"))
    for group in spec.optional:
        if len(group) == 3 and group[0].short in _VECTOR_NAMES:
            out.append(_Param(name_of(_VECTOR_NAMES[group[0].short]), tuple(group), "vec"))
        else:
            for f in group:
                out.append(_Param(name_of(f.short), (f,), "opt"))
    if spec.variadic is not None:
        out.append(_Param(name_of(spec.variadic.short + "s"), (spec.variadic,), "var"))
    return out


def _vector_required(spec: KeywordSpec, params: list[_Param]) -> list[_Param]:
    """An element whose vector is required (WHEEL's axle, BEAMC's centre) takes it as one
    tuple too: its last three required fields become one "vec" parameter."""
    if not spec.is_element or len(spec.required) < 4:
        return params
    last = spec.required[-3:]
    if last[0].short not in _VECTOR_NAMES or params[-1].how != "req":
        return params
    kept = params[:-3]
    return kept + [_Param(_VECTOR_NAMES[last[0].short], tuple(last), "vecreq")]


def _groups_of(spec: KeywordSpec, params: list[_Param]) -> list[list[_Param]]:
    """The parameters of each optional group (all-or-nothing, in order)."""
    groups, i = [], 0
    opt = [p for p in params if p.how in ("opt", "vec")]
    for group in spec.optional:
        members = []
        n = 0
        while n < len(group):
            p = opt[i]
            members.append(p)
            n += len(p.fields)
            i += 1
        groups.append(members)
    return groups


def _doc(spec: KeywordSpec, params: list[_Param], part: str) -> str:
    lines = [f"``{spec.usage}``: {spec.summary}.", ""]
    if part == "output":
        lines += ["Goes into the third module (the linearized system's inputs and "
                  "outputs).", ""]
    lines += ["Parameters", "----------"]
    for p in params:
        if p.how in ("vec", "vecreq"):
            what = ", ".join(f.name for f in p.fields)
            lines += [f"{p.name} : tuple of 3 numbers" + (", optional" if p.how == "vec"
                                                          else ""), f"    ({what})"]
        elif p.how == "var":
            f = p.fields[0]
            lines += [f"*{p.name} : {KIND_DESCRIPTIONS[f.kind]}", f"    {f.name}"
                      + (" (ranges such as ``range(1, 7)`` allowed)" if f.kind == "int"
                         else "")]
        else:
            f = p.fields[0]
            sel = spec.range_first and p is params[0]
            kind = ("a number, a range or a list" if sel else KIND_DESCRIPTIONS[f.kind])
            lines += [f"{p.name} : {kind}" + (", optional" if p.how == "opt" else ""),
                      f"    {f.name}"
                      + (f" (one of {', '.join(f.choices)})" if f.choices else "")]
    lines += ["", "Returns", "-------", "ModelBuilder", "    The builder (calls chain).",
              "", "Raises", "------", "DeckError",
              "    An argument the deck field cannot hold (naming the method and the "
              "argument)."]
    if spec.extension:
        lines += ["", "A spacarpy extension (docs/deck.md)."]
    return "\n".join(lines)


def keyword_method(spec: KeywordSpec, method: str | None = None):
    """The builder method of keyword ``spec`` (named ``method``, default its lower-case
    name)."""
    name = method or spec.name.lower()
    params = _vector_required(spec, _params(spec))
    groups = _groups_of(spec, params)
    part = PART_OF[spec.name]
    sig_params = [inspect.Parameter("self", inspect.Parameter.POSITIONAL_OR_KEYWORD)]
    for p in params:
        if p.how == "var":
            sig_params.append(inspect.Parameter(p.name, inspect.Parameter.VAR_POSITIONAL))
        else:
            default = None if p.how in ("opt", "vec") else inspect.Parameter.empty
            sig_params.append(inspect.Parameter(p.name, inspect.Parameter.POSITIONAL_OR_KEYWORD,
                                                default=default))
    signature = inspect.Signature(sig_params)

    def method_fn(self, *args, **kwargs):
        try:
            bound = signature.bind(self, *args, **kwargs)
        except TypeError as exc:
            return self._refuse(f"ModelBuilder.{name}(): {exc} (usage: {spec.usage})")
        try:
            return _record(self, bound.arguments)
        except ValueError as exc:
            return self._refuse(str(exc))

    def _record(self, values):
        fields: list = []
        first = None
        for p in params:
            if p.how in ("opt", "vec"):
                continue
            if p.how == "var":
                for v in values.get(p.name, ()):
                    if isinstance(v, range) and p.fields[0].kind == "int":
                        fields += [check_field(name, p.name, p.fields[0], k) for k in v]
                    else:
                        fields.append(check_field(name, p.name, p.fields[0], v))
                continue
            v = values[p.name]
            if p.how == "vecreq":
                fields += _vector(name, p, v)
            elif spec.range_first and p is params[0]:
                first = _selection(name, p.name, p.fields[0], v)
            else:
                fields.append(check_field(name, p.name, p.fields[0], v))
        opt_fields, missing = [], None
        for members in groups:
            given = [values.get(p.name) is not None for p in members]
            if not any(given):
                missing = missing or members
                continue
            if not all(given):
                absent = [p.name for p, g in zip(members, given) if not g]
                raise ValueError(f"ModelBuilder.{name}(): give {', '.join(absent)} too "
                                 f"(these fields go together: {spec.usage})")
            if missing is not None:
                raise ValueError(f"ModelBuilder.{name}(): {members[0].name} needs "
                                 f"{missing[0].name} (the fields are positional: "
                                 f"{spec.usage})")
            for p in members:
                opt_fields += (_vector(name, p, values[p.name]) if p.how == "vec"
                               else [check_field(name, p.name, p.fields[0], values[p.name])])
        if spec.variadic is not None and values.get(params[-1].name) and missing is not None:
            raise ValueError(f"ModelBuilder.{name}(): *{params[-1].name} needs every "
                             f"optional field before it ({spec.usage})")
        # order: required, optional groups, variadic (the variadic values were appended to
        # ``fields`` after the required ones; put the optional fields between)
        n_fixed = sum(len(p.fields) for p in params if p.how in ("req", "vecreq"))
        if first is not None:
            n_fixed -= 1
        record = fields[:n_fixed] + opt_fields + fields[n_fixed:]
        return self._emit(PART_OF[spec.name], spec.name, first, record)

    method_fn.__name__ = method_fn.__qualname__ = name
    method_fn.__signature__ = signature
    method_fn.__doc__ = _doc(spec, params, part)
    return method_fn


def _vector(method: str, p: _Param, value) -> list:
    if isinstance(value, (str, bytes)) or not isinstance(value, Iterable):
        raise ValueError(f"ModelBuilder.{method}(): {p.name} must be three numbers "
                         f"({', '.join(f.short for f in p.fields)}), got {value!r}")
    items = list(value)
    if len(items) != len(p.fields):
        raise ValueError(f"ModelBuilder.{method}(): {p.name} must be {len(p.fields)} numbers "
                         f"({', '.join(f.short for f in p.fields)}), got {len(items)}")
    return [check_field(method, p.name, f, v) for f, v in zip(p.fields, items)]


#: Keyword name -> method, for every keyword a script can give (the SPACAR keywords spacarpy
#: does not implement have none: they would be refused when the model is built).
KEYWORD_METHODS = {name: keyword_method(spec) for name, spec in KEYWORDS.items()
                   if spec.supported and name not in _NO_METHOD}
