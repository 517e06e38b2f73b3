"""A small, safe expression language for constraints and visibility rules (no bpy, no eval).

Grammar (a subset of Python's): numbers, `true`/`false`, parameter names, `+ - * /`, unary `-`,
comparisons `== != < <= > >=` (chains like `0 < x < 1` mean `0 < x and x < 1`), `and`, `or`,
`not`, parentheses. Text is parsed with `ast` and every node is checked against a whitelist;
anything else raises `ExprError` with a one-line message. Nothing is ever compiled or run.

Evaluation semantics: numbers are floats, comparisons give bools, `and`/`or`/`not` use
truthiness (non-zero is true) and give bools. Division follows IEEE floats (x/0 is +-inf, 0/0 is
nan, and nan compares false). Each node implements its rule once, over batches
(`evaluate_array`); `evaluate` runs it on scalars, so a constraint checked one shape at a time
and over a batch always agree.

Round trip: `parse(str(e)) == e` for every tree. To keep that true, unary minus on a number
literal is folded into the literal (`-1` is `Const(-1)`), and `Neg(Const(number))` is refused.
"""

from __future__ import annotations

import ast
import functools
import keyword
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

import numpy as np

__all__ = [
    "ExprError",
    "Expr",
    "Const",
    "Name",
    "Compare",
    "BinOp",
    "Neg",
    "Not",
    "And",
    "Or",
    "parse",
    "all_of",
    "any_of",
    "negate",
    "TRUE",
    "FALSE",
]

MAX_TEXT = 10_000  # a rule longer than this is a mistake; also keeps ast recursion shallow
LITERALS = {"true": True, "false": False}
COMPARE_OPS = ("==", "!=", "<", "<=", ">", ">=")
BINARY_OPS = ("+", "-", "*", "/")

# Printing precedence, mirroring Python's: a child of lower precedence gets parentheses.
PREC_OR, PREC_AND, PREC_NOT, PREC_COMPARE, PREC_ADD, PREC_MUL, PREC_NEG, PREC_ATOM = range(1, 9)


class ExprError(ValueError):
    """A bad expression, or one that cannot be evaluated; the message is one line."""


class Expr:
    """Base of the immutable expression tree."""

    precedence = PREC_ATOM

    def evaluate(self, values: Mapping[str, float]) -> float | bool:
        """The value for one set of values: the batch rule (`evaluate_array`) on scalars, so a
        rule checked one shape at a time and over a batch cannot disagree."""
        return self.evaluate_array(values).item()

    def evaluate_array(self, columns: Mapping[str, np.ndarray | float]) -> np.ndarray:
        """Evaluate over a batch: `columns` maps names to 1-d arrays (or scalars, broadcast)."""
        raise NotImplementedError

    def names(self) -> frozenset[str]:
        raise NotImplementedError

    def _child_str(self, child: Expr, min_precedence: int) -> str:
        text = str(child)
        return f"({text})" if child.precedence < min_precedence else text


@dataclass(frozen=True)
class Const(Expr):
    value: float | bool

    def __post_init__(self):
        if not isinstance(self.value, (bool, int, float)) or isinstance(self.value, complex):
            raise ExprError(f"constant {self.value!r} is not a number or bool")
        try:
            finite = math.isfinite(self.value)
        except OverflowError:  # an int too large for a float
            finite = False
        if not finite:
            raise ExprError(f"constant {_shorten(self.value)} is not a finite float")

    @property
    def precedence(self):
        is_negative = not isinstance(self.value, bool) and self.value < 0
        return PREC_NEG if is_negative else PREC_ATOM

    def evaluate_array(self, columns):
        return np.asarray(self.value)

    def names(self):
        return frozenset()

    def __str__(self):
        if isinstance(self.value, bool):
            return "true" if self.value else "false"
        return repr(self.value)  # repr of a float round-trips exactly


TRUE, FALSE = Const(True), Const(False)


@dataclass(frozen=True)
class Name(Expr):
    id: str

    def __post_init__(self):
        valid = isinstance(self.id, str) and self.id.isidentifier()
        if not valid or keyword.iskeyword(self.id) or self.id in LITERALS:
            raise ExprError(f"{self.id!r} cannot be a parameter name")

    def evaluate_array(self, columns):
        try:
            return np.asarray(columns[self.id])
        except KeyError:
            raise ExprError(f"no value for {self.id!r}") from None

    def names(self):
        return frozenset({self.id})

    def __str__(self):
        return self.id


_COMPARE = {
    "==": lambda a, b: a == b,
    "!=": lambda a, b: a != b,
    "<": lambda a, b: a < b,
    "<=": lambda a, b: a <= b,
    ">": lambda a, b: a > b,
    ">=": lambda a, b: a >= b,
}


@dataclass(frozen=True)
class Compare(Expr):
    left: Expr
    op: str
    right: Expr
    precedence = PREC_COMPARE

    def __post_init__(self):
        if self.op not in COMPARE_OPS:
            raise ExprError(f"unknown comparison {self.op!r}; use one of {' '.join(COMPARE_OPS)}")

    def evaluate_array(self, columns):
        return _COMPARE[self.op](
            self.left.evaluate_array(columns), self.right.evaluate_array(columns)
        )

    def names(self):
        return self.left.names() | self.right.names()

    def __str__(self):
        # Both sides above comparison level: `(a < b) == c` must not print as a chain.
        left = self._child_str(self.left, PREC_COMPARE + 1)
        return f"{left} {self.op} {self._child_str(self.right, PREC_COMPARE + 1)}"


_ARITHMETIC = {
    "+": lambda a, b: a + b,
    "-": lambda a, b: a - b,
    "*": lambda a, b: a * b,
}


@dataclass(frozen=True)
class BinOp(Expr):
    op: str
    left: Expr
    right: Expr

    def __post_init__(self):
        if self.op not in BINARY_OPS:
            raise ExprError(f"unknown operator {self.op!r}; use one of {' '.join(BINARY_OPS)}")

    @property
    def precedence(self):
        return PREC_ADD if self.op in "+-" else PREC_MUL

    def evaluate_array(self, columns):
        left = self.left.evaluate_array(columns).astype(np.float64)
        right = self.right.evaluate_array(columns).astype(np.float64)
        if self.op == "/":
            with np.errstate(divide="ignore", invalid="ignore"):
                return left / right
        return _ARITHMETIC[self.op](left, right)

    def names(self):
        return self.left.names() | self.right.names()

    def __str__(self):
        # Left-associative: the right child needs strictly higher precedence, a - (b - c).
        left = self._child_str(self.left, self.precedence)
        return f"{left} {self.op} {self._child_str(self.right, self.precedence + 1)}"


@dataclass(frozen=True)
class Neg(Expr):
    x: Expr
    precedence = PREC_NEG

    def __post_init__(self):
        if isinstance(self.x, Const) and not isinstance(self.x.value, bool):
            raise ExprError("write a negative number as Const(-v), not Neg(Const(v))")

    def evaluate_array(self, columns):
        return -self.x.evaluate_array(columns).astype(np.float64)

    def names(self):
        return self.x.names()

    def __str__(self):
        return f"-{self._child_str(self.x, PREC_NEG)}"


@dataclass(frozen=True)
class Not(Expr):
    x: Expr
    precedence = PREC_NOT

    def evaluate_array(self, columns):
        return np.logical_not(self.x.evaluate_array(columns))

    def names(self):
        return self.x.names()

    def __str__(self):
        return f"not {self._child_str(self.x, PREC_NOT)}"


@dataclass(frozen=True)
class _BoolOp(Expr):
    """Shared body of And / Or: a tuple of at least two items."""

    items: tuple

    word = ""

    def __post_init__(self):
        object.__setattr__(self, "items", tuple(self.items))  # lists arrive from callers
        if len(self.items) < 2:
            raise ExprError(f"{type(self).__name__} needs two or more items; use all_of / any_of")
        if not all(isinstance(item, Expr) for item in self.items):
            raise ExprError(f"{type(self).__name__} items must be expressions")

    def evaluate_array(self, columns):
        return functools.reduce(self.combine, (item.evaluate_array(columns) for item in self.items))

    def names(self):
        return frozenset().union(*(item.names() for item in self.items))

    def __str__(self):
        # Nested and/or of the same kind keep their parentheses, so the tree round-trips.
        return f" {self.word} ".join(self._child_str(i, self.precedence + 1) for i in self.items)


class And(_BoolOp):
    precedence = PREC_AND
    word = "and"
    combine = np.logical_and


class Or(_BoolOp):
    precedence = PREC_OR
    word = "or"
    combine = np.logical_or


# ---------------------------------------------------------------- parsing

_AST_COMPARE = {
    ast.Eq: "==",
    ast.NotEq: "!=",
    ast.Lt: "<",
    ast.LtE: "<=",
    ast.Gt: ">",
    ast.GtE: ">=",
}
_AST_BINARY = {ast.Add: "+", ast.Sub: "-", ast.Mult: "*", ast.Div: "/"}
_DESCRIBE = {
    ast.Call: "function calls",
    ast.Attribute: "attribute access",
    ast.Subscript: "subscripts",
    ast.Lambda: "lambdas",
    ast.NamedExpr: "assignment",
    ast.IfExp: "if-else",
}


def parse(text: str, names: Iterable[str] | None = None) -> Expr:
    """Parse `text`; with `names`, any other name is an error. Raises ExprError (one line)."""
    if not isinstance(text, str):
        raise ExprError(f"expression must be a string, got {type(text).__name__}")
    shown = _shorten(text)
    if len(text) > MAX_TEXT:
        raise ExprError(f"expression {shown} is longer than {MAX_TEXT} characters")
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError as exc:
        raise ExprError(f"expression {shown} is not valid syntax ({exc.msg})") from None
    except (RecursionError, MemoryError, ValueError):
        raise ExprError(f"expression {shown} is too deeply nested or malformed") from None
    allowed = None if names is None else frozenset(names)
    try:
        return _Converter(allowed).convert(tree.body)
    except ExprError as exc:
        raise ExprError(f"expression {shown}: {exc}") from None
    except RecursionError:
        raise ExprError(f"expression {shown} is too deeply nested") from None


def _shorten(text: str, limit: int = 80) -> str:
    text = " ".join(str(text).split())  # keep messages on one line
    return repr(text if len(text) <= limit else text[: limit - 3] + "...")


class _Converter:
    """Turns a whitelisted Python ast into Expr nodes; rejects everything else."""

    def __init__(self, allowed: frozenset[str] | None):
        self.allowed = allowed

    def convert(self, node: ast.AST) -> Expr:
        method = getattr(self, f"_{type(node).__name__}", None)
        if method is None:
            what = _DESCRIBE.get(type(node), f"{type(node).__name__} syntax")
            raise ExprError(
                f"{what} not allowed; use numbers, names, + - * /, comparisons, and/or/not"
            )
        return method(node)

    def _Constant(self, node):
        if type(node.value) not in (bool, int, float):
            raise ExprError(f"literal {node.value!r} not allowed; only numbers, true and false")
        return Const(node.value)

    def _Name(self, node):
        if node.id in LITERALS:
            return Const(LITERALS[node.id])
        if node.id.startswith("__"):
            raise ExprError(f"name {node.id!r} not allowed")
        if self.allowed is not None and node.id not in self.allowed:
            raise ExprError(
                f"unknown name {node.id!r}; check the spelling against the program's parameters"
            )
        return Name(node.id)

    def _UnaryOp(self, node):
        operand = self.convert(node.operand)
        if isinstance(node.op, ast.Not):
            return Not(operand)
        if isinstance(node.op, ast.UAdd):
            return operand
        if isinstance(node.op, ast.USub):
            if isinstance(operand, Const) and not isinstance(operand.value, bool):
                return Const(-operand.value)
            return Neg(operand)
        raise ExprError("operator ~ not allowed")

    def _BinOp(self, node):
        op = _AST_BINARY.get(type(node.op))
        if op is None:
            raise ExprError(f"operator {type(node.op).__name__} not allowed; use + - * /")
        return BinOp(op, self.convert(node.left), self.convert(node.right))

    def _BoolOp(self, node):
        items = tuple(self.convert(value) for value in node.values)
        return And(items) if isinstance(node.op, ast.And) else Or(items)

    def _Compare(self, node):
        operands = [self.convert(node.left)] + [self.convert(c) for c in node.comparators]
        parts = []
        for op, left, right in zip(node.ops, operands[:-1], operands[1:], strict=True):
            symbol = _AST_COMPARE.get(type(op))
            if symbol is None:
                raise ExprError(f"comparison {type(op).__name__} not allowed; use == != < <= > >=")
            parts.append(Compare(left, symbol, right))
        return parts[0] if len(parts) == 1 else And(tuple(parts))


# ---------------------------------------------------------------- building and simplifying


def all_of(items: Iterable[Expr]) -> Expr:
    """Conjunction, simplified: nested ands flattened, duplicates and `true` dropped,
    `false` (or `x and not x`) absorbs everything; none -> true, one -> itself."""
    return _combine(And, items, identity=True)


def any_of(items: Iterable[Expr]) -> Expr:
    """Disjunction, simplified like all_of (with `x or not x` -> true), and absorption:
    `a or (a and b)` -> `a`."""
    return _combine(Or, items, identity=False)


def negate(x: Expr) -> Expr:
    """`not x`, simplified: constants flip, double negation cancels."""
    if isinstance(x, Const) and isinstance(x.value, bool):
        return Const(not x.value)
    if isinstance(x, Not):
        return x.x
    return Not(x)


def _combine(kind: type, items: Iterable[Expr], identity: bool) -> Expr:
    flat: list[Expr] = []
    for item in _flatten(kind, items):
        if isinstance(item, Const):
            if bool(item.value) == identity:
                continue  # `true and x` -> x
            return Const(not identity)  # `false and x` -> false
        if item not in flat:
            flat.append(item)
    present = set(flat)
    if any(isinstance(i, Not) and i.x in present for i in flat):
        return Const(not identity)  # x and not x -> false; x or not x -> true
    flat = _absorb(kind, flat)
    if not flat:
        return Const(identity)
    return flat[0] if len(flat) == 1 else kind(tuple(flat))


def _flatten(kind: type, items: Iterable[Expr]):
    for item in items:
        if not isinstance(item, Expr):
            raise ExprError(f"{item!r} is not an expression")
        if isinstance(item, kind):
            yield from item.items
        else:
            yield item


def _absorb(kind: type, flat: list[Expr]) -> list[Expr]:
    """Drop an item whose inner terms include all terms of another item:
    `a or (a and b)` -> `a`, `a and (a or b)` -> `a`."""
    inner = Or if kind is And else And

    def terms(item):
        return set(item.items) if isinstance(item, inner) else {item}

    term_sets = [terms(item) for item in flat]
    kept = []
    for i, item in enumerate(flat):
        absorbed = any(j != i and term_sets[j] < term_sets[i] for j in range(len(flat)))
        if not absorbed:
            kept.append(item)
    return kept
