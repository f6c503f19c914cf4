"""Shorted valves (``R = 0``): which the lumped model must contract, and the contraction that
merges their end nodes (docs/model.md §3.8)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from hisopt.hydraulics.layout import Circuit, Element, Layout, Pipe, Valve
from hisopt.hydraulics.network import Network


def singular_shorts(network: Network, shorted: frozenset[int]) -> frozenset[int]:
    """The shorted valves (element indices, ``R = 0``) the lumped model cannot keep.

    A short leaves the descriptor's algebraic part regular unless shorts join two nodes that
    store oil (their pressures would be equal, with the flow between them undetermined) or
    close a loop. Those shorts, every short of such a group of nodes, must be contracted
    (:func:`contract_shorts`); the others are exact as they are.
    """
    parent = list(range(network.size))

    def root(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    loops: set[int] = set()
    for k in sorted(shorted):
        a, b = network.element_rows[k][:2]
        ra, rb = root(a), root(b)
        if ra == rb:
            loops.add(ra)
        else:
            parent[rb] = ra
    storing: dict[int, int] = {}
    for i in np.flatnonzero(network.dynamic & ~network.is_flow):
        storing[root(int(i))] = storing.get(root(int(i)), 0) + 1
    bad = {r for r, count in storing.items() if count > 1} | {root(r) for r in loops}
    return frozenset(k for k in shorted if root(network.element_rows[k][0]) in bad)


def contract_shorts(layout: Layout, shorted: frozenset[int]) -> Layout:
    """``layout`` with the valves of element indices ``shorted`` (``R = 0``) removed and
    their end nodes merged: compliances joined by a short are one compliance.

    Element indices count across circuits, as :attr:`Network.elements`.
    """
    return contracted_layout(layout, shorted)[0]


def contracted_layout(layout: Layout, shorted: frozenset[int]) -> tuple[Layout, tuple[int, ...]]:
    """:func:`contract_shorts` and, per element of the contracted layout, the element index
    it had in ``layout`` (a valve left joining a node to itself is dropped: it carries no flow)."""
    out = []
    origin: list[int] = []
    k = 0
    for circuit in layout.circuits:
        alias: dict[str, str] = {}  # merged node -> the node it joined
        kept: list[tuple[int, Element]] = []
        for element in circuit.elements:
            if k in shorted and isinstance(element, Valve):
                a, b = _root(alias, element.a), _root(alias, element.b)
                if a != b:
                    alias[b] = a
            else:
                kept.append((k, element))
            k += 1
        renamed = [(i, _rename(e, alias)) for i, e in kept]
        renamed = [(i, e) for i, e in renamed if not (isinstance(e, Valve) and e.a == e.b)]
        origin += [i for i, _ in renamed]
        ports = tuple(replace(p, node=_root(alias, p.node)) for p in circuit.ports)
        out.append(Circuit(circuit.name, tuple(e for _, e in renamed), ports))
    return Layout(tuple(out), layout.name), tuple(origin)


def _root(alias: dict[str, str], name: str) -> str:
    while name in alias:
        name = alias[name]
    return name


def _rename(element: Element, alias: dict[str, str]) -> Element:
    if isinstance(element, (Valve, Pipe)):
        return replace(element, a=_root(alias, element.a), b=_root(alias, element.b))
    return replace(element, node=_root(alias, element.node))
