"""What several commands share: the ``--set`` and ``--scenario`` options, ``--debug``'s
switch and :func:`load`, which reads a problem file with them (the other shared option types
are in :mod:`hisopt.cli.usage`)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from hisopt.cli.usage import scalar_fields

# The keys --set accepts: the scalar fields of the [his] table (RollPlaneHIS), read from its
# source so that `hisopt --help` need not import the model (and numpy).
SET_KEYS = scalar_fields("hisopt.hydraulics.roll_plane", "RollPlaneHIS")

SetOpt = Annotated[
    list[str] | None,
    typer.Option(
        "--set",
        metavar="KEY=VALUE",
        help='override a [his] value of the problem file, e.g. --set p0=3e6 or --set "p0=2.5 MPa" (repeatable; '
        f"bare numbers are SI, a value may carry its unit); KEY is one of {', '.join(SET_KEYS)}",
    ),
]

ScenarioOpt = Annotated[
    str | None,
    typer.Option("--scenario", metavar="NAME", help="a [[scenarios]] load case (its road and payload); default the problem's [road], no payload"),
]

# --debug (set by the app's callback): re-raise internal errors for their tracebacks.
DEBUG = {"on": False}


def load(problem: Path, sets: list[str] | None, scenario: str | None = None):
    """Load a problem file, apply ``--set`` overrides (:func:`hisopt.specification.validation.apply_assignments`)
    and, with ``--scenario``, take that load case as a single-case problem."""
    from hisopt.errors import ConfigError
    from hisopt.problem import load_problem
    from hisopt.specification.validation import apply_assignments

    p = apply_assignments(load_problem(problem), sets)
    if scenario is None:
        return p
    if scenario not in p.scenario_names:
        known = f"one of {', '.join(p.scenario_names)}" if p.scenario_names else "a problem with [[scenarios]] (this one has none), or no --scenario"
        raise ConfigError(f"unknown scenario {scenario!r}; expected {known}", key="--scenario")
    return p.scenario_space(scenario)
