"""Every HIS interconnection up to a number of parts: the candidates of ``hisopt synthesize``.

A layout is a set of circuits; a circuit is a connected graph of *nodes* joined by valves
(docs/model.md §20). The enumeration builds circuits from *hubs*, as HIS schematics are
drawn: each hub carries one accumulator, mounted on it directly or behind a valve; each
cylinder chamber of the circuit feeds one hub, directly or through its own damper valve;
link valves join the hubs of a circuit. Chambers in no circuit are vented (as today).

The elements counted against the budget ``K`` are the accumulators and the valves: a
roll-plane HIS has 6 (two accumulators, four chamber valves), an accumulator behind a valve
costs 2. An orifice is a valve in every linear engine (its equivalent resistance), so it
is the same topology and is not enumerated apart.

What the hub rules would generate twice or in vain is taken out on the *node graph* (each
node: its chambers and whether it holds an accumulator; each edge a valve):

- two candidates are one when their node graphs are isomorphic with the chambers fixed
  (the nodes relabelled; networkx's VF2, :func:`networkx.is_isomorphic`), and, unless the
  search keeps asymmetric layouts apart, when one is the other's left-right mirror image;
- a node with no chamber and no accumulator joined to fewer than three valves is a valve in
  series with another (discarded: one valve does it);
- a circuit without a chamber does nothing; every hub holds an accumulator, so no circuit
  is a closed volume without compliance that would lock a mode rigidly.

By default only mirror-symmetric layouts are enumerated (``symmetric=True``): a car turns
both ways, and a layout that is not its own mirror image rolls differently in left and right
turns. ``symmetric=False`` keeps every layout, a layout and its mirror image counted once.

Layouts are composed from the circuits: a mirror-symmetric layout is a set of circuits that
are their own mirror image and of pairs of mirror-image circuits, with disjoint chambers.
"""

from __future__ import annotations

import itertools
from collections import defaultdict
from collections.abc import Iterator, Sequence
from dataclasses import dataclass

import networkx as nx

from hisopt.hydraulics.layout import CHAMBER_LABELS, Accumulator, Circuit, Layout, Port, Valve, chamber_of_label

MIRROR_WHEEL_LABEL = {"1": "2", "2": "1", "3": "4", "4": "3"}
CHAMBER_SETS: dict[str, tuple[str, ...]] = {
    "all": CHAMBER_LABELS,
    "front": tuple(c for c in CHAMBER_LABELS if c[0] in "12"),
    "rear": tuple(c for c in CHAMBER_LABELS if c[0] in "34"),
}
"""The chambers ``--chambers`` offers: ``front`` gives single-axle layouts (the rear keeps its
conventional struts: its chambers vented)."""

ACCUMULATOR_VALVE, LINK_VALVE = "Rv_acc", "Rv_link"
"""Parameter names of a valve in front of an accumulator and of a valve between hubs; a
chamber's damper valve is ``Rv`` (front wheels) or ``Rv_rear`` (rear wheels), as in the
catalogue."""


MAX_HUBS = 2
"""[-] Hubs (accumulators) per circuit: the catalogue's largest circuits have two, a front and a
rear one; each further hub multiplies the candidates (K = 8 takes minutes with three) without
a layout in the literature that uses it."""


def mirror_chamber(label: str) -> str:
    """``"1t"`` -> ``"2t"``: the same chamber on the other side of the car."""
    return MIRROR_WHEEL_LABEL[label[0]] + label[1]


# --- node graphs ------------------------------------------------------------------------------
def element_count(graph: nx.Graph) -> int:
    """[-] Accumulators plus valves of a node graph."""
    return graph.number_of_edges() + sum(1 for _, acc in graph.nodes(data="acc") if acc)


def node_match(a: dict, b: dict) -> bool:
    """Whether two nodes are alike: the same chambers, both or neither with an accumulator."""
    return bool(a["chambers"] == b["chambers"] and a["acc"] == b["acc"])


def _label(graph: nx.Graph, v: int) -> tuple[tuple[str, ...], bool]:
    return tuple(sorted(graph.nodes[v]["chambers"])), bool(graph.nodes[v]["acc"])


def bucket_key(graph: nx.Graph) -> tuple:
    """An isomorphism invariant (each node's label with its neighbours' labels): graphs with
    different keys are not isomorphic; within a key :func:`networkx.is_isomorphic` decides."""
    return tuple(sorted((_label(graph, v), tuple(sorted(_label(graph, w) for w in graph[v]))) for v in graph.nodes))


def mirrored(graph: nx.Graph) -> nx.Graph:
    """The node graph with every chamber moved to the other side of the car."""
    out = graph.copy()
    for v in out.nodes:
        out.nodes[v]["chambers"] = frozenset(mirror_chamber(c) for c in graph.nodes[v]["chambers"])
    return out


def redundant(graph: nx.Graph) -> bool:
    """Whether a node graph does what a smaller one does, or nothing (module docstring)."""
    for comp in nx.connected_components(graph):
        if not any(graph.nodes[v]["chambers"] for v in comp) or not any(graph.nodes[v]["acc"] for v in comp):
            return True
    return any(not d["chambers"] and not d["acc"] and graph.degree(v) < 3 for v, d in graph.nodes(data=True))


class IsomorphismClasses:
    """Node graphs up to isomorphism (chambers fixed): :meth:`find` and :meth:`add`."""

    def __init__(self) -> None:
        self.graphs: list[nx.Graph] = []
        self._buckets: dict[tuple, list[int]] = defaultdict(list)

    def find(self, graph: nx.Graph) -> int | None:
        """Index of the class of ``graph`` (None: a new one)."""
        for i in self._buckets.get(bucket_key(graph), ()):
            if nx.is_isomorphic(graph, self.graphs[i], node_match=node_match):
                return i
        return None

    def add(self, graph: nx.Graph) -> int:
        """Index of the class of ``graph``, added when new."""
        found = self.find(graph)
        if found is not None:
            return found
        self.graphs.append(graph)
        self._buckets[bucket_key(graph)].append(len(self.graphs) - 1)
        return len(self.graphs) - 1


# --- hub structures ----------------------------------------------------------------------------
@dataclass(frozen=True)
class _Hubs:
    """Hubs ``0 .. n-1`` with the mirror map ``sigma`` (identity for an asymmetric search)."""

    n: int
    sigma: tuple[int, ...]

    def orbits(self) -> list[tuple[int, ...]]:
        return sorted({tuple(sorted({h, self.sigma[h]})) for h in range(self.n)})

    def link_orbits(self) -> list[tuple[tuple[int, int], ...]]:
        out: dict[tuple[int, int], tuple[tuple[int, int], ...]] = {}
        for a, b in itertools.combinations(range(self.n), 2):
            x, y = sorted((self.sigma[a], self.sigma[b]))
            image = (x, y)
            key = min((a, b), image)
            out[key] = tuple(sorted({(a, b), image}))
        return [out[k] for k in sorted(out)]


def _hub_sets(n: int, symmetric: bool) -> Iterator[_Hubs]:
    """Every mirror map of ``n`` hubs up to relabelling: ``f`` fixed hubs and ``p`` swapped pairs."""
    if not symmetric:
        yield _Hubs(n, tuple(range(n)))
        return
    for p in range(n // 2 + 1):
        f = n - 2 * p
        sigma = list(range(f)) + [x for j in range(p) for x in (f + 2 * j + 1, f + 2 * j)]
        yield _Hubs(n, tuple(sigma))


def _connected(n: int, links: Sequence[tuple[int, int]]) -> bool:
    graph = nx.Graph()
    graph.add_nodes_from(range(n))
    graph.add_edges_from(links)
    return nx.is_connected(graph)


def _fate_options(hubs: _Hubs, symmetric: bool) -> list[tuple[tuple[str, int, bool], ...] | None]:
    """What can become of a chamber unit (a chamber, or a mirror pair left/right): vented
    (None) or fed into hubs, directly or through a valve: ``((side, hub, valved), ...)``."""
    options: list[tuple[tuple[str, int, bool], ...] | None] = [None]
    for valved in (False, True):
        for h in range(hubs.n):
            if not symmetric:
                options.append((("only", h, valved),))
            elif hubs.sigma[h] == h:
                options.append((("left", h, valved), ("right", h, valved)))
            else:
                options.append((("left", h, valved), ("right", hubs.sigma[h], valved)))
    return options


def _units(chambers: Sequence[str], paired: bool) -> list[dict[str, str]]:
    """Chamber units: single chambers, or (``paired``) a left chamber with its mirror image."""
    if not paired:
        return [{"only": c} for c in chambers]
    return [{"left": c, "right": mirror_chamber(c)} for c in chambers if c[0] in "13" and mirror_chamber(c) in chambers]


def _one_side_options(hubs: _Hubs) -> list[tuple[tuple[str, int, bool], ...] | None]:
    """Fates of a mirror pair of chambers of which at most one side is used."""
    return [None] + [((side, h, valved),) for valved in (False, True) for side in ("left", "right") for h in range(hubs.n)]


def _node_graph(hubs: _Hubs, links: Sequence[tuple[int, int]], valved_acc: Sequence[bool], feeds: list[tuple[str, int, bool]]) -> nx.Graph:
    graph = nx.Graph()
    direct: list[set[str]] = [set() for _ in range(hubs.n)]
    for chamber, hub, valved in feeds:
        if not valved:
            direct[hub].add(chamber)
    for h in range(hubs.n):
        graph.add_node(h, chambers=frozenset(direct[h]), acc=not valved_acc[h])
    node = hubs.n
    for h in range(hubs.n):
        if valved_acc[h]:
            graph.add_node(node, chambers=frozenset(), acc=True)
            graph.add_edge(h, node)
            node += 1
    for chamber, hub, valved in feeds:
        if valved:
            graph.add_node(node, chambers=frozenset((chamber,)), acc=False)
            graph.add_edge(hub, node)
            node += 1
    graph.add_edges_from(links)
    return graph


@dataclass(frozen=True)
class _Frame:
    """Hubs with their links and accumulator mounts, before the chambers are placed."""

    hubs: _Hubs
    links: tuple[tuple[int, int], ...]
    valved_acc: tuple[bool, ...]
    options: list
    spare: int  # elements left for chamber valves


def _frames(max_elements: int, symmetric: bool, one_side: bool) -> Iterator[_Frame]:
    for n in range(1, min(max_elements, MAX_HUBS) + 1):
        for hubs in _hub_sets(n, symmetric):
            orbits, link_orbits = hubs.orbits(), hubs.link_orbits()
            options = _one_side_options(hubs) if one_side else _fate_options(hubs, symmetric)
            for count in range(len(link_orbits) + 1):
                for chosen in itertools.combinations(link_orbits, count):
                    links = tuple(e for orbit in chosen for e in orbit)
                    if n + len(links) > max_elements or not _connected(n, links):
                        continue
                    for acc_modes in itertools.product((False, True), repeat=len(orbits)):
                        valved_acc = [False] * n
                        for orbit, valved in zip(orbits, acc_modes, strict=True):
                            for h in orbit:
                                valved_acc[h] = valved
                        spare = max_elements - n - len(links) - sum(valved_acc)
                        if spare >= 0:
                            yield _Frame(hubs, links, tuple(valved_acc), options, spare)


def circuit_structures(chambers: Sequence[str], max_elements: int, symmetric: bool, one_side: bool = False) -> Iterator[nx.Graph]:
    """Every labelled hub structure of one connected circuit with at most ``max_elements``
    elements, before duplicates and redundant ones are taken out.

    ``symmetric``: only circuits that are their own mirror image; ``one_side``: only circuits
    that hold no chamber together with its mirror image (those that can pair with their
    mirror image in a symmetric layout).
    """
    units = _units(chambers, symmetric or one_side)
    for frame in _frames(max_elements, symmetric, one_side):
        yield from _with_chambers(frame.hubs, list(frame.links), list(frame.valved_acc), units, frame.options, frame.spare)


def structure_count(chambers: Sequence[str], max_elements: int, symmetric: bool, one_side: bool = False) -> int:
    """[-] How many structures :func:`circuit_structures` yields, counted without building
    them (the work of an enumeration, known before it starts)."""
    units = _units(chambers, symmetric or one_side)
    total = 0
    for frame in _frames(max_elements, symmetric, one_side):
        # per unit: the number of its fates at each chamber-valve cost; their product's
        # coefficients up to the spare budget, less the all-vented choice
        poly = [1]
        for _ in units:
            terms: dict[int, int] = defaultdict(int)
            for fate in frame.options:
                terms[0 if fate is None else sum(v for _, _, v in fate)] += 1
            new = [0] * (len(poly) + max(terms))
            for i, a in enumerate(poly):
                for cost, b in terms.items():
                    new[i + cost] += a * b
            poly = new
        total += sum(poly[: frame.spare + 1]) - 1
    return total


def _with_chambers(
    hubs: _Hubs, links: list[tuple[int, int]], valved_acc: list[bool], units: list[dict[str, str]], options: list, spare: int
) -> Iterator[nx.Graph]:
    for fates in itertools.product(options, repeat=len(units)):
        feeds = [(unit[side], hub, valved) for unit, fate in zip(units, fates, strict=True) if fate is not None for side, hub, valved in fate]
        if not feeds or sum(valved for _, _, valved in feeds) > spare:
            continue
        yield _node_graph(hubs, links, valved_acc, feeds)


def circuit_classes(chambers: Sequence[str], max_elements: int, symmetric: bool, one_side: bool = False) -> list[nx.Graph]:
    """One node graph per distinct, non-redundant circuit (:func:`circuit_structures`), in
    the order first generated."""
    classes = IsomorphismClasses()
    for graph in circuit_structures(chambers, max_elements, symmetric, one_side):
        if not redundant(graph):
            classes.add(graph)
    return classes.graphs


# --- layouts -------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Candidate:
    """One enumerated layout: the indices of its circuits in :attr:`Enumeration.circuits`."""

    circuits: tuple[int, ...]
    elements: int


@dataclass
class Enumeration:
    """The circuits and the layouts composed of them (:func:`enumerate_layouts`)."""

    circuits: list[nx.Graph]
    candidates: list[Candidate]
    chambers: tuple[str, ...]
    symmetric: bool
    max_elements: int
    classes: IsomorphismClasses

    def graph(self, candidate: Candidate) -> nx.Graph:
        """The node graph of a whole layout (circuits side by side)."""
        return nx.disjoint_union_all([self.circuits[i] for i in candidate.circuits])


def _mask(graph: nx.Graph) -> int:
    bits = 0
    for _, chambers in graph.nodes(data="chambers"):
        for c in chambers:
            bits |= 1 << CHAMBER_LABELS.index(c)
    return bits


def _compose(units: list[tuple[tuple[int, ...], int, int]], max_elements: int) -> Iterator[tuple[tuple[int, ...], int]]:
    """Every non-empty set of units ``(circuits, cost, chamber mask)`` with disjoint chambers
    and total cost at most ``max_elements`` (each set once: units in increasing index)."""
    import numpy as np

    costs = np.array([u[1] for u in units], dtype=np.int64)
    masks = np.array([u[2] for u in units], dtype=np.int64)

    def walk(start: int, mask: int, cost: int, chosen: tuple[int, ...]) -> Iterator[tuple[tuple[int, ...], int]]:
        fits = np.flatnonzero((costs[start:] <= max_elements - cost) & ((masks[start:] & mask) == 0)) + start
        for i in fits.tolist():
            picked = chosen + units[i][0]
            yield picked, cost + units[i][1]
            yield from walk(i + 1, mask | units[i][2], cost + units[i][1], picked)

    yield from walk(0, 0, 0, ())


def search_structure_count(max_elements: int, chambers: str | Sequence[str] = "all", symmetric: bool = True) -> int:
    """[-] The circuit structures :func:`enumerate_layouts` examines: its work, known up front."""
    labels = chamber_labels(chambers, symmetric)
    if symmetric:
        return structure_count(labels, max_elements, True) + structure_count(labels, max_elements // 2, False, one_side=True)
    return structure_count(labels, max_elements, False)


def composition_count(units: list[tuple[tuple[int, ...], int, int]], max_elements: int) -> int:
    """[-] How many layouts :func:`_compose` yields, counted without composing them: the
    number of sets of units with disjoint chambers and total cost at most ``max_elements``."""
    import numpy as np

    masks = np.arange(1 << len(CHAMBER_LABELS))
    ways = np.zeros((masks.size, max_elements + 1), dtype=np.int64)
    ways[0, 0] = 1
    for _, cost, mask in units:
        if cost > max_elements:
            continue
        free = masks[(masks & mask) == 0]
        ways[free | mask, cost:] += ways[free, : max_elements + 1 - cost]
    return int(ways.sum()) - 1


def _circuit_units(
    labels: tuple[str, ...], max_elements: int, symmetric: bool
) -> tuple[IsomorphismClasses, list[tuple[tuple[int, ...], int, int]], dict[int, int | None]]:
    """The distinct circuits and the units a layout is composed of (module docstring)."""
    classes = IsomorphismClasses()
    if symmetric:
        generic = circuit_classes(labels, max_elements // 2, symmetric=False, one_side=True)
    else:
        generic = circuit_classes(labels, max_elements, symmetric=False)
    for graph in generic:
        classes.add(graph)
    units: list[tuple[tuple[int, ...], int, int]] = []
    mirror_of: dict[int, int | None] = {}
    if symmetric:
        for graph in circuit_classes(labels, max_elements, symmetric=True):
            i = classes.add(graph)
            units.append(((i,), element_count(graph), _mask(graph)))
        for i, graph in enumerate(generic):
            j = classes.find(mirrored(graph))
            if j is not None and j > i:
                units.append(((i, j), 2 * element_count(graph), _mask(graph) | _mask(classes.graphs[j])))
        units.sort(key=lambda u: u[0])
    else:
        mirror_of = {i: classes.find(mirrored(g)) for i, g in enumerate(generic)}
        units = [((i,), element_count(g), _mask(g)) for i, g in enumerate(generic)]
    return classes, units, mirror_of


def candidate_count(max_elements: int, chambers: str | Sequence[str] = "all", symmetric: bool = True) -> int:
    """[-] How many candidates :func:`enumerate_layouts` gives, from the circuits alone (a
    layout and its mirror image are one: Burnside's count, (all + symmetric) / 2)."""
    labels = chamber_labels(chambers, symmetric)
    total = composition_count(_circuit_units(labels, max_elements, symmetric)[1], max_elements)
    if symmetric:
        return total
    return (total + composition_count(_circuit_units(labels, max_elements, True)[1], max_elements)) // 2


def chamber_labels(chambers: str | Sequence[str], symmetric: bool) -> tuple[str, ...]:
    """The chambers of a search (:data:`CHAMBER_SETS` name or labels), checked."""
    labels = CHAMBER_SETS[chambers] if isinstance(chambers, str) else tuple(chambers)
    if symmetric and any(mirror_chamber(c) not in labels for c in labels):
        raise ValueError(f"a mirror-symmetric search needs both sides of every chamber; got {', '.join(labels)}")
    return labels


def enumerate_layouts(max_elements: int, chambers: str | Sequence[str] = "all", symmetric: bool = True) -> Enumeration:
    """Every distinct layout of at most ``max_elements`` elements (module docstring), ordered
    by element count, then as composed.

    Parameters
    ----------
    max_elements : int
        [-] the budget ``K``: accumulators plus valves
    chambers : str | Sequence[str], optional
        [-] ``"all"``, ``"front"``, ``"rear"`` (:data:`CHAMBER_SETS`) or chamber labels;
        the others are vented
    symmetric : bool, optional
        only layouts that are their own left-right mirror image (default)
    """
    labels = chamber_labels(chambers, symmetric)
    classes, units, mirror_of = _circuit_units(labels, max_elements, symmetric)
    found: list[Candidate] = []
    for circuits, cost in _compose(units, max_elements):
        key = tuple(sorted(circuits))
        if not symmetric and tuple(sorted(mirror_of[i] for i in key)) < key:  # type: ignore[type-var]
            continue  # the mirror image is the one kept
        found.append(Candidate(key, cost))
    found.sort(key=lambda c: (c.elements, c.circuits))
    return Enumeration(classes.graphs, found, labels, symmetric, max_elements, classes)


# --- a node graph as a layout ---------------------------------------------------------------------
def valve_parameter(graph: nx.Graph, a: int, b: int) -> str:
    """The resistance parameter of the valve between nodes ``a`` and ``b`` (module constants)."""
    for v in (a, b):
        d = graph.nodes[v]
        if len(d["chambers"]) == 1 and not d["acc"] and graph.degree(v) == 1:
            (chamber,) = d["chambers"]
            return "Rv" if chamber_of_label(chamber)[0] < 2 else "Rv_rear"
    for v in (a, b):
        d = graph.nodes[v]
        if d["acc"] and not d["chambers"] and graph.degree(v) == 1:
            return ACCUMULATOR_VALVE
    return LINK_VALVE


def node_names(graph: nx.Graph, circuit: str) -> dict[int, str]:
    """Readable node names: ``A.1t3t`` (its chambers), ``A.acc1`` (an accumulator alone)."""
    names: dict[int, str] = {}
    counters: dict[str, int] = defaultdict(int)
    for v in sorted(graph.nodes, key=lambda v: (_label(graph, v), v)):
        d = graph.nodes[v]
        stem = "".join(sorted(d["chambers"])) or ("acc" if d["acc"] else "j")
        counters[stem] += 1
        names[v] = f"{circuit}.{stem}" + (str(counters[stem]) if not d["chambers"] else "")
    return names


def circuit_of_graph(graph: nx.Graph, name: str) -> Circuit:
    """The :class:`~hisopt.hydraulics.layout.Circuit` of a one-circuit node graph."""
    names = node_names(graph, name)
    order = sorted(graph.nodes, key=lambda v: names[v])
    elements: list = [Accumulator(names[v]) for v in order if graph.nodes[v]["acc"]]
    edges = sorted((min(names[a], names[b]), max(names[a], names[b]), a, b) for a, b in graph.edges)
    elements += [Valve(x, y, valve_parameter(graph, a, b)) for x, y, a, b in edges]
    ports = [Port(names[v], *chamber_of_label(c)) for v in order for c in sorted(graph.nodes[v]["chambers"])]
    return Circuit(name, tuple(elements), tuple(ports))


def candidate_layout(enumeration: Enumeration, candidate: Candidate, name: str) -> Layout:
    """The layout of a candidate, its circuits named A, B, C, ..."""
    return Layout(tuple(circuit_of_graph(enumeration.circuits[i], chr(ord("A") + k)) for k, i in enumerate(candidate.circuits)), name)


def layout_graphs(layout: Layout) -> list[nx.Graph]:
    """One node graph per circuit of a layout (accumulators and valves; orifices count as
    valves; the layout must hold no pipes or oil volumes)."""
    graphs = []
    for circuit in layout.circuits:
        graph = nx.Graph()
        index = {n: i for i, n in enumerate(circuit.nodes)}
        for n, i in index.items():
            graph.add_node(i, chambers=frozenset(p.label for p in circuit.ports if p.node == n), acc=False)
        for e in circuit.elements:
            if isinstance(e, Accumulator):
                graph.nodes[index[e.node]]["acc"] = True
            elif isinstance(e, Valve):
                graph.add_edge(index[e.a], index[e.b])
            else:
                raise ValueError(f"circuit {circuit.name!r}: a {type(e).__name__} is not among the synthesised elements")
        graphs.append(graph)
    return graphs


def describe(enumeration: Enumeration, candidate: Candidate) -> str:
    """A one-line description: per circuit its nodes (chambers, ``acc``; ``junction``: valves
    only) and its valves with their resistance parameters."""
    parts = []
    for k, i in enumerate(candidate.circuits):
        circuit = circuit_of_graph(enumeration.circuits[i], chr(ord("A") + k))
        nodes = {n: [p.label for p in circuit.ports if p.node == n] for n in circuit.nodes}
        for e in circuit.elements:
            if isinstance(e, Accumulator):
                nodes[e.node].append("acc")
        text = " ".join(f"({' '.join(v) or 'junction'})" for v in nodes.values())
        valves = " ".join(f"{e.a.split('.', 1)[1]}~{e.b.split('.', 1)[1]}:{e.resistance}" for e in circuit.elements if isinstance(e, Valve))
        parts.append(f"{circuit.name}: {text}" + (f" valves {valves}" if valves else ""))
    return "; ".join(parts)
