"""The layouts of a layout study: one problem per layout, built from the study's problem.

A layout study (:mod:`hisopt.studies.layout_study`) optimises every layout on the study
problem's vehicle, road, band, comfort settings, objectives, constraints and optimiser
settings. Each layout gets its own problem (:func:`layout_case`):

- a catalogue layout (``hisopt layouts``) replaces the ``[his]`` layout; ``[his.parameters]``
  entries it does not read are dropped (its catalogue defaults apply);
- a custom layout is a problem file (``path/to/custom.toml``): it contributes its layout only
  (``[his] layout``, ``[[his.circuits]]``, ``[his.parameters]``) and the bounds of its
  layout's extra parameters from its ``[variables]``; its name in the study is the file's stem.

Design variables: the study problem's ``[variables]`` the layout reads, plus the layout's
extra parameters with bounds (the custom file's ``[variables]``, else the catalogue's
``[variables]``, docs/model.md §12.3); extra parameters without bounds stay at their
defaults. Layouts whose design variables differ are compared on their objectives only.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from hisopt.errors import ConfigError
from hisopt.hydraulics.catalogue import CATALOGUE_NAMES, CUSTOM, catalogue, his_layout, layout_defaults, used_parameters
from hisopt.hydraulics.roll_plane import RollPlaneHIS

if TYPE_CHECKING:
    from hisopt.problem import Problem

REFERENCE_LAYOUT = "roll_plane"
"""The paper's layout: the reference of ``gain_vs_roll_plane_pct``, always in a study."""

CONVENTIONAL = "conventional"
"""The car without circuits, with anti-roll bars (:mod:`hisopt.studies.conventional`): the
reference of ``gain_vs_conventional_pct``, in a study when ``--layouts`` names it. It is
sized, not optimised, so it is no :class:`LayoutCase`."""

_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]*")


@dataclass(frozen=True)
class LayoutCase:
    """One layout of a study.

    Attributes
    ----------
    name : str
        [-] catalogue name, or the stem of the custom layout's problem file
    problem : Problem
        the study problem with this layout and its design variables
    source : str
        [-] ``"catalogue"`` or the custom problem file's path
    """

    name: str
    problem: Problem
    source: str


def parse_layout_list(text: str | Sequence[str] | None) -> list[str]:
    """``"roll_plane,axle_roll"`` (or a list) -> items; None: the whole catalogue.

    Raises
    ------
    ConfigError
        An empty list or an item given twice.
    """
    if text is None:
        return list(CATALOGUE_NAMES)
    items = [p.strip() for p in text.split(",")] if isinstance(text, str) else [str(p).strip() for p in text]
    items = [p for p in items if p]
    if not items:
        raise ConfigError(f"expected layout names or problem files separated by commas, got {text!r}", key="--layouts")
    twice = [p for i, p in enumerate(items) if p in items[:i]]
    if twice:
        raise ConfigError(f"{twice[0]!r} is listed twice; expected each layout once", key="--layouts")
    return items


def _with_layout(problem: Problem, name: str, his_update: dict[str, Any], bounds: dict[str, dict[str, Any]]) -> Problem:
    """``problem`` with ``[his]`` updated and the variables the new layout reads."""
    from hisopt.problem import problem_from_dict

    data = problem.spec.model_dump(by_alias=True)
    data["his"].update(his_update)
    data["name"] = f"{problem.name}-{name}"
    variables = {**data["variables"], **{k: v for k, v in bounds.items() if k not in data["variables"]}}
    his = RollPlaneHIS.model_validate(data["his"])
    read = used_parameters(his_layout(his)) | set(layout_defaults(his))
    data["variables"] = {k: v for k, v in variables.items() if k in read}
    return problem_from_dict(data, f"{problem.name}, layout {name}", warn_implausible=False)  # checked when read


def catalogue_case(problem: Problem, name: str) -> LayoutCase:
    """The study problem with catalogue layout ``name`` (module docstring)."""
    entry = catalogue()[name]
    his = problem.spec.his
    params = {k: v for k, v in his.parameters.items() if k in entry.parameters}
    bounds = {k: b.model_dump() for k, b in entry.variables.items()}
    update = {"layout": name, "circuits": None, "parameters": params}
    return LayoutCase(name, _with_layout(problem, name, update, bounds), "catalogue")


def file_case(problem: Problem, path: Path) -> LayoutCase:
    """The study problem with the layout of problem file ``path`` (module docstring)."""
    from hisopt.problem import load_problem

    other = load_problem(path)
    his = other.spec.his
    name = path.stem
    if name in CATALOGUE_NAMES or not _NAME.fullmatch(name):
        raise ConfigError(f"{path}: its name {name!r} must differ from the catalogue's and use letters, digits, _ . -", key="--layouts")
    extras = layout_defaults(his)
    bounds = {k: v.model_dump() for k, v in other.spec.variables.items() if k in extras}
    if his.layout != CUSTOM:
        bounds = {**{k: b.model_dump() for k, b in catalogue()[his.layout].variables.items()}, **bounds}
    dumped = other.spec.his.model_dump(by_alias=True)
    update = {"layout": his.layout, "circuits": dumped["circuits"], "parameters": dict(his.parameters)}
    return LayoutCase(name, _with_layout(problem, name, update, bounds), str(path))


def layout_case(problem: Problem, item: str) -> LayoutCase:
    """A catalogue name or a problem file's path -> its :class:`LayoutCase`.

    Raises
    ------
    ConfigError
        Neither a catalogue name nor an existing ``.toml`` file (or that file is invalid).
    """
    if item in CATALOGUE_NAMES:
        return catalogue_case(problem, item)
    path = Path(item)
    if path.suffix == ".toml" and path.is_file():
        return file_case(problem, path)
    if path.suffix == ".toml":
        raise ConfigError(f"layout file {item!r} not found; expected a problem file with the custom layout", key="--layouts")
    raise ConfigError(
        f"unknown layout {item!r}; expected one of {', '.join(CATALOGUE_NAMES)}, {CONVENTIONAL} or a problem file (.toml) with a custom layout",
        key="--layouts",
    )


def wants_conventional(layouts: str | Sequence[str] | None) -> bool:
    """[-] Whether a study's ``--layouts`` name :data:`CONVENTIONAL`."""
    return layouts is not None and CONVENTIONAL in parse_layout_list(layouts)


def layout_cases(problem: Problem, layouts: str | Sequence[str] | None = None) -> list[LayoutCase]:
    """Every layout of a study, :data:`REFERENCE_LAYOUT` first (added when not asked for);
    :data:`CONVENTIONAL` is not one (:func:`wants_conventional`).

    Raises
    ------
    ConfigError
        As :func:`parse_layout_list` and :func:`layout_case`; two files with the same stem.
    """
    items = [p for p in parse_layout_list(layouts) if p != CONVENTIONAL]
    if REFERENCE_LAYOUT not in items:
        items.insert(0, REFERENCE_LAYOUT)
    else:
        items.insert(0, items.pop(items.index(REFERENCE_LAYOUT)))
    cases = [layout_case(problem, item) for item in items]
    names = [c.name for c in cases]
    twice = [n for i, n in enumerate(names) if n in names[:i]]
    if twice:
        raise ConfigError(f"two layouts are named {twice[0]!r}; expected distinct file names", key="--layouts")
    return cases
