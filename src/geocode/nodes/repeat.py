"""Repeat zones: a loop inside a node tree, for parts whose count is a parameter and whose
shape depends on the pass (rows of drawers, each following the body's profile where it sits).

    zone = Repeat(g, rows, geometry=None, bottom=0.0)   # the state: named items
    ... build one pass from zone.iteration, zone["bottom"], zone["geometry"] ...
    result = zone.close(geometry=joined, bottom=top)     # result["geometry"]: after all passes

An item's type comes from its initial value (None: a geometry). Values from outside the zone
may be used inside it directly.
"""

from __future__ import annotations

from geocode.nodes.graph import Graph, Node, Value, data_type_of


class Repeat:
    """One repeat zone of `g`, open until `close` connects the state of the next pass."""

    def __init__(self, g: Graph, iterations: Value, **items: Value):
        self.g = g
        self._input = g.node("GeometryNodeRepeatInput")
        self._output = g.node("GeometryNodeRepeatOutput")
        self._input.bl.pair_with_output(self._output.bl)
        self._output.bl.repeat_items.clear()
        for name, value in items.items():
            kind = "GEOMETRY" if value is None else data_type_of(value)
            self._output.bl.repeat_items.new(kind, name)
        g.set(self._input.input("Iterations"), iterations)
        for name, value in items.items():
            if value is not None:
                g.set(self._input.input(name), value)
        self._names = list(items)

    @property
    def iteration(self):
        """The pass's index, 0 for the first."""
        return self._input["Iteration"]

    def __getitem__(self, name: str):
        """The item's value at the start of this pass."""
        return self._input[name]

    def close(self, **items: Value) -> Node:
        """Connect each item's value for the next pass; the node's outputs hold the items
        after the last pass (their initial values when there is none)."""
        missing = set(self._names) - set(items)
        if missing or set(items) - set(self._names):
            raise TypeError(f"repeat zone items are {self._names}; got {sorted(items)}")
        for name, value in items.items():
            if value is not None:
                self.g.set(self._output.input(name), value)
        return self._output
