"""Deck semantics, the state-space signals: INPUTF, INPUTS, OUTX, OUTXP, OUTE and OUTEP.

The inputs and outputs of the linearized system of SPACAR mode 9 (docs/deck.md,
"Linearization output"): ``INPUTF i n c`` (input i is a force on coordinate c of node n),
``INPUTS i e k`` (input i is a stress resultant on deformation k of element e),
``OUTX i n c`` / ``OUTXP i n c`` (output i is the position / velocity of coordinate c of node
n) and ``OUTE i e k`` / ``OUTEP i e k`` (output i is deformation k of element e / its rate).
In a planar model a position node has the coordinates 1, 2 (x, y) and an orientation node
the one coordinate 1, its rotation about z (as for INPUTX). Checked here: nodes and elements
that do not exist, coordinate and mode numbers out of range,
and the numbering: the inputs and the outputs are each numbered from 1, every number once (the
four output keywords share one numbering, as in SPACAR's output vector). A number without a
line (a gap, as where a real deck comments an INPUTS line out) is a zero column or row of the
state space and draws a warning naming it.
"""
from __future__ import annotations

from spacarpy.deck.semantics.errors import DeckContext, ErrorCollector
from spacarpy.deck.semantics.topology import NODE_SIZE, Topology, UsesTopology
from spacarpy.deck.statement import Statement
from spacarpy.settings import SystemSignal

__all__ = ["INPUT_KEYWORDS", "OUTPUT_KEYWORDS", "from_statements"]

INPUT_KEYWORDS = ("INPUTF", "INPUTS")
OUTPUT_KEYWORDS = ("OUTX", "OUTXP", "OUTE", "OUTEP")
_NODE_KEYWORDS = ("INPUTF", "OUTX", "OUTXP")


class _SignalsPass(UsesTopology):
    def __init__(self, ctx: DeckContext, errors: ErrorCollector, topology: Topology,
                 fix_lines: dict | None = None):
        self.ctx, self.errors, self.topology = ctx, errors, topology
        self.fix_lines = fix_lines or {}

    def signal(self, st: Statement) -> SystemSignal | None:
        i, target, number = st.fields[0], st.fields[1], st.fields[2]
        if st.keyword in _NODE_KEYWORDS:
            kind = self.node_kind(target)
            if kind is None:
                if target not in self.foreign_nodes and target not in self.quiet_nodes:
                    self.error(st.field_locs[1], f"{st.keyword}: node {target} is not defined "
                                                 "(no X line and not used by any element)", st)
                return None
            n_coord = NODE_SIZE[kind]
            if self.planar:
                n_coord = 2 if kind == "position" else 1
            if not 1 <= number <= n_coord:
                what = ("x y z"[:2 * n_coord - 1] if kind == "position"
                        else "the rate of twist" if kind == "warping"
                        else "the rotation about z" if self.planar else "lambda0..lambda3")
                self.error(st.field_locs[2], f"{st.keyword}: node {target} is "
                                             f"{'an' if kind == 'orientation' else 'a'} {kind} "
                                             "node: "
                                             f"coordinate 1..{n_coord} ({what}), got {number}",
                           st)
                return None
            fix = self.fix_lines.get((target, number)) if not self.planar else None
            if st.keyword == "INPUTF" and fix is not None:
                self.error(st.field_locs[2], f"INPUTF: coordinate {number} of node {target} "
                                             f"is fixed (FIX at line {fix.loc.line}): an input "
                                             "force there goes straight into the support "
                                             "(its B column would be zero); remove the INPUTF "
                                             "or the FIX", st)
                return None
        else:
            rec = self.beams.get(target)
            if rec is None:
                if target not in self.foreign_elements and target not in self.quiet_elements:
                    self.error(st.field_locs[1], f"{st.keyword}: element {target} is not "
                                                 "defined (no element line)", st)
                return None
            n_def = rec.info["n_def"]
            if not 1 <= number <= n_def:
                self.error(st.field_locs[2], f"{st.keyword}: element {target} "
                                             f"({rec.keyword}) has deformation modes "
                                             f"1..{n_def}, got {number}", st)
                return None
        return SystemSignal(st.keyword, int(i), int(target), int(number), loc=st.loc)

    def numbered(self, sts: list[Statement], what: str) -> tuple:
        """The signals of ``sts`` ordered by index; the indices must be 1..n, each once."""
        seen: dict[int, Statement] = {}
        out = []
        for st in sts:
            i = st.fields[0]
            if i in seen:
                self.error(st.field_locs[0], f"{st.keyword}: {what} {i} is already defined "
                                             f"(line {seen[i].loc.line})", st)
                continue
            seen[i] = st
            sig = self.signal(st)
            if sig is not None:
                out.append(sig)
        missing = sorted(set(range(1, max(seen, default=0) + 1)) - set(seen))
        if missing:
            last = max(seen)
            self.errors.warn(f"{seen[last].loc}: {what}s are numbered up to {last}, but "
                             f"{what} number{'s' * (len(missing) > 1)} "
                             f"{', '.join(map(str, missing))} "
                             f"{'have' if len(missing) > 1 else 'has'} no line: "
                             f"{'zero columns' if what == 'input' else 'zero rows'} of the "
                             "state space")
        return tuple(sorted(out, key=lambda s: s.index))


def from_statements(by_kw: dict, ctx: DeckContext, errors: ErrorCollector,
                    topology: Topology, fix_lines: dict | None = None) -> tuple[tuple, tuple]:
    """(inputs, outputs): the :class:`~spacarpy.settings.SystemSignal` s of the deck, each
    ordered by its index. ``fix_lines``: (node, coordinate) -> FIX line (an INPUTF on a
    fixed coordinate is an error, as a DELXF there is)."""
    part = _SignalsPass(ctx, errors, topology, fix_lines)
    inputs = part.numbered(ctx.in_deck_order(*INPUT_KEYWORDS), "input")
    outputs = part.numbered(ctx.in_deck_order(*OUTPUT_KEYWORDS), "output")
    return inputs, outputs
