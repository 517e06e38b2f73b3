"""Infer parameter visibility from a node graph (docs/paper-numbers.md#labels).

A group input is visible where some path from it to the group output is live. A path is
live when every Switch / Index Switch / Menu Switch it passes through through a *data*
input selects that input: `Switch` through True needs its selector true, through False
needs it false; `Index Switch` through item i needs `index == i`. Passing through a switch's
selector adds no condition. Paths enter node groups and come back out of them, so switches
inside blocks count, with their selectors rewritten in terms of the program's inputs.

The rule of an input is the disjunction over its paths of the conjunction of their
conditions, simplified (duplicates, constants, absorption `a or (a and b)` -> `a`).
A Menu Switch fed by a constant menu selects its one item; one fed by a link (a menu can
only come from a menu input, never from a bool/int/float parameter) may select any item.
A selector the translator cannot express (a field, an unsupported node) counts as
"possibly selected", so an input is never hidden by mistake.
"""

from __future__ import annotations

import sys

from geocode.expr import (
    TRUE,
    BinOp,
    Compare,
    Const,
    Expr,
    Name,
    all_of,
    any_of,
    negate,
)

Conjunction = frozenset  # of Expr atoms
DNF = frozenset  # of Conjunction; empty = unreachable, {frozenset()} = always

_COMPARE_OPS = {"LESS_THAN": "<", "LESS_EQUAL": "<=", "GREATER_THAN": ">",
                "GREATER_EQUAL": ">=", "EQUAL": "==", "NOT_EQUAL": "!="}
_MATH_OPS = {"ADD": "+", "SUBTRACT": "-", "MULTIPLY": "*", "DIVIDE": "/"}
_VALUE_TYPES = {"VALUE", "INT", "BOOLEAN"}
_MAX_TERMS = 256  # a rule larger than this is kept as "always" rather than explode


def infer_visibility(tree) -> dict[str, Expr | None]:
    """Group input name -> its visibility rule (None = always visible; geometry inputs
    are left out)."""
    sys.setrecursionlimit(max(sys.getrecursionlimit(), 20_000))  # deep graphs recurse deep
    walker = _Walker()
    rules = {}
    for group_input in _nodes(tree, "NodeGroupInput"):
        for socket in group_input.outputs:
            if socket.type in ("CUSTOM", "GEOMETRY") or socket.name in rules:
                continue
            dnf = walker.reach_from_output(socket, ())
            rules[socket.name] = _to_rule(dnf)
    return rules


def _to_rule(dnf: DNF) -> Expr | None:
    if frozenset() in dnf or len(dnf) > _MAX_TERMS:
        return None
    terms = sorted((all_of(sorted(c, key=str)) for c in dnf), key=str)
    rule = any_of(terms)
    return None if rule == TRUE else rule


def _nodes(tree, bl_idname: str):
    return [node for node in tree.nodes if node.bl_idname == bl_idname]


def _socket_key(socket) -> tuple:
    return (socket.id_data.name, socket.node.name, socket.is_output, socket.identifier)


class _Walker:
    """Memoised walk over (socket, group-node context) pairs."""

    def __init__(self):
        self._memo: dict[tuple, DNF] = {}

    def _memoised(self, socket, context: tuple, compute) -> DNF:
        """Each (socket, group context) is walked once: subgraphs used by several paths stay linear."""
        key = (_socket_key(socket), tuple((n.id_data.name, n.name) for n in context))
        if key not in self._memo:
            self._memo[key] = compute(socket, context)
        return self._memo[key]

    def reach_from_output(self, socket, context: tuple) -> DNF:
        return self._memoised(socket, context, self._reach_out)

    def reach_from_input(self, socket, context: tuple) -> DNF:
        return self._memoised(socket, context, self._reach_in)

    def _reach_out(self, socket, context: tuple) -> DNF:
        """An output socket reaches the result through any of its links."""
        result: set = set()
        for link in socket.links:
            if link.is_muted or not link.is_valid:
                continue
            result |= self.reach_from_input(link.to_socket, context)
        return _prune(result)

    def _reach_in(self, socket, context: tuple) -> DNF:
        node = socket.node
        kind = node.bl_idname
        if kind == "NodeGroupOutput":
            return self._leave_group(socket, context)
        if kind == "GeometryNodeGroup" and node.node_tree is not None:
            return self._enter_group(socket, node, context)
        if kind == "NodeReroute":
            return self.reach_from_output(node.outputs[0], context)
        branch = _branch_condition(self, socket, node, context)
        downstream: set = set()
        for output in _live_outputs(node, kind):
            downstream |= self.reach_from_output(output, context)
        return _and(frozenset(downstream), branch)

    def _leave_group(self, socket, context: tuple) -> DNF:
        if not socket.node.is_active_output:
            return frozenset()
        if not context:
            return frozenset({frozenset()})  # the program's output: always live from here
        group_node, outer = context[-1], context[:-1]
        for output in group_node.outputs:
            if output.identifier == socket.identifier:
                return self.reach_from_output(output, outer)
        return frozenset()

    def _enter_group(self, socket, node, context: tuple) -> DNF:
        result: set = set()
        for inner in _nodes(node.node_tree, "NodeGroupInput"):
            for output in inner.outputs:
                if output.identifier == socket.identifier:
                    result |= self.reach_from_output(output, context + (node,))
        return _prune(result)

    # -- selector expressions ---------------------------------------------------------------

    def expression_of_input(self, socket, context: tuple) -> Expr | None:
        links = [link for link in socket.links if not link.is_muted and link.is_valid]
        if not links:
            return _constant(socket)
        return self.expression_of_output(links[0].from_socket, context)

    def expression_of_output(self, socket, context: tuple) -> Expr | None:
        node = socket.node
        kind = node.bl_idname
        if kind == "NodeGroupInput":
            if not context:
                return Name(socket.name) if socket.type in _VALUE_TYPES else None
            group_node, outer = context[-1], context[:-1]
            for outer_socket in group_node.inputs:
                if outer_socket.identifier == socket.identifier:
                    return self.expression_of_input(outer_socket, outer)
            return None
        if kind == "NodeReroute":
            return self.expression_of_input(node.inputs[0], context)
        if kind == "GeometryNodeGroup" and node.node_tree is not None:
            for inner in _nodes(node.node_tree, "NodeGroupOutput"):
                if inner.is_active_output:
                    for inner_socket in inner.inputs:
                        if inner_socket.identifier == socket.identifier:
                            return self.expression_of_input(inner_socket, context + (node,))
            return None
        return _fold(self._operation(node, kind, context))

    def _operation(self, node, kind: str, context: tuple) -> Expr | None:
        operands = [self.expression_of_input(s, context) for s in node.inputs if s.enabled]
        if kind == "FunctionNodeCompare":
            if node.data_type not in ("FLOAT", "INT") or node.mode != "ELEMENT":
                return None
            op = _COMPARE_OPS.get(node.operation)
            a, b = operands[0], operands[1]
            return None if op is None or a is None or b is None else Compare(a, op, b)
        if kind in ("ShaderNodeMath", "FunctionNodeIntegerMath"):
            op = _MATH_OPS.get(node.operation)
            if op is None or None in operands[:2]:
                return None
            return BinOp(op, operands[0], operands[1])
        if kind == "FunctionNodeBooleanMath":
            if None in operands:
                return None
            if node.operation == "NOT":
                return negate(operands[0])
            if node.operation == "AND":
                return all_of(operands[:2])
            if node.operation == "OR":
                return any_of(operands[:2])
            return None
        if kind in ("ShaderNodeValue", "FunctionNodeInputInt", "FunctionNodeInputBool"):
            return _constant(node.outputs[0])
        return None


def _live_outputs(node, kind: str):
    """The outputs a signal entering `node` can leave by (all of them but bookkeeping)."""
    return [s for s in node.outputs if s.enabled and s.type != "CUSTOM"]


def _branch_condition(walker: _Walker, socket, node, context: tuple) -> Expr | None:
    """The condition for `socket` (a data input of a switch) to be the one passed on;
    None where it is not a switch's data input."""
    kind = node.bl_idname
    if kind == "GeometryNodeSwitch" and socket.identifier in ("True", "False"):
        selector = walker.expression_of_input(node.inputs["Switch"], context)
        if selector is None:
            return TRUE
        selector = _as_bool(selector)
        return selector if socket.identifier == "True" else _fold(_negate(selector))
    if kind == "GeometryNodeIndexSwitch" and socket.identifier.startswith("Item_"):
        index = walker.expression_of_input(node.inputs["Index"], context)
        if index is None:
            return TRUE
        position = int(socket.identifier.removeprefix("Item_"))
        return _fold(Compare(index, "==", Const(position)))
    if kind == "GeometryNodeMenuSwitch" and socket.identifier.startswith("Item_"):
        return _menu_condition(node, socket)
    return None


def _menu_condition(node, socket) -> Expr:
    """A menu chosen by a constant selects one item; a linked menu may select any."""
    menu = node.inputs["Menu"]
    if menu.is_linked:
        return TRUE
    position = int(socket.identifier.removeprefix("Item_"))
    names = [item.name for item in node.enum_items]
    return Const(position < len(names) and names[position] == menu.default_value)


_INVERSE = {"<": ">=", "<=": ">", ">": "<=", ">=": "<", "==": "!=", "!=": "=="}


def _negate(expr: Expr) -> Expr:
    """`not expr`, with a comparison turned into its inverse (`a > 0` -> `a <= 0`)."""
    if isinstance(expr, Compare):
        return Compare(expr.left, _INVERSE[expr.op], expr.right)
    return negate(expr)


def _as_bool(expr: Expr) -> Expr:
    """A number used as a Switch selector is true when non-zero."""
    if isinstance(expr, (Compare,)) or expr.__class__.__name__ in ("And", "Or", "Not"):
        return expr
    if isinstance(expr, Const):
        return Const(bool(expr.value))
    if isinstance(expr, Name):
        return expr  # bool inputs: the name itself reads as the condition
    return Compare(expr, "!=", Const(0))


def _constant(socket) -> Expr | None:
    if socket.type not in _VALUE_TYPES or not hasattr(socket, "default_value"):
        return None
    value = socket.default_value
    if socket.type == "BOOLEAN":
        return Const(bool(value))
    return Const(int(value) if socket.type == "INT" else float(value))


def _fold(expr: Expr | None) -> Expr | None:
    """Expressions without names collapse to their value."""
    if expr is None or expr.names():
        return expr
    value = expr.evaluate({})
    return Const(value if isinstance(value, bool) else value)


def _and(dnf: DNF, condition: Expr | None) -> DNF:
    if condition is None or condition == TRUE:
        return dnf
    if condition == Const(False):
        return frozenset()
    return _prune({conjunction | {condition} for conjunction in dnf})


def _prune(terms) -> DNF:
    """Drop conjunctions that contain another one (absorption) and contradictory ones."""
    terms = [t for t in set(terms) if not _contradictory(t)]
    terms.sort(key=len)
    kept: list = []
    for term in terms:
        if not any(other <= term for other in kept):
            kept.append(term)
    return frozenset(kept)


def _contradictory(term: frozenset) -> bool:
    return any(_negate(atom) in term for atom in term)
