"""A design as a sheet to build from (docs/model.md §17.4): its parts and settings, its
quantities in every load case, its operating envelope and its modes, its buildability (every
rule, docs/model.md §21), and the problem file that reproduces it.

:func:`design_sheet` gathers the numbers (SI, with units in each table's ``attrs``);
:mod:`hisopt.report.sheet` writes them as Markdown, HTML and TOML.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from hisopt.coupled.modal import modal_analysis
from hisopt.hydraulics import laws
from hisopt.hydraulics.layout import DamperValve
from hisopt.hydraulics.network import resolve
from hisopt.problem import Problem
from hisopt.studies import damper_valves
from hisopt.studies.buildability import load_case_rules, rule_sheet
from hisopt.studies.envelope import envelope_table
from hisopt.studies.verified import VERIFY_JSON, VerifiedDesign, read_verification, same_design, verify_folder

MODE_COLUMNS = ("mode", "motion", "frequency_hz", "damping_ratio")
"""The modes' columns a sheet shows."""


@dataclass(frozen=True)
class DesignSheet:
    """One design of a run, ready to build (module docstring).

    Attributes
    ----------
    problem : Problem
        the run's problem with the design's values in ``[his]`` (its baseline is the design)
    design : int
        [-] the design's row in the run's front (``front.csv``, from 0)
    source : str
        where the design comes from (the front file)
    parts : pd.DataFrame
        ``item``, ``value`` [SI], ``unit``, ``note``: the bill of parts and settings
    quantities : pd.DataFrame
        one row: the design's quantities (each load case's too), as ``hisopt evaluate`` gives them
    envelope : pd.DataFrame
        :func:`hisopt.studies.envelope.envelope_table` of the design
    modes : pd.DataFrame
        :data:`MODE_COLUMNS` of its modes with HIS
    valves : pd.DataFrame
        its physical damper valves' settings
        (:func:`hisopt.studies.damper_valves.valve_settings`; no rows without damper valves)
    valve_cases : pd.DataFrame
        per load case and valve its RMS flow, equivalent resistance and whether that lies in
        the validated range (:func:`hisopt.studies.damper_valves.valve_table`)
    valve_modes : pd.DataFrame
        per load case the roll and bounce (heave) modes' frequency and damping ratio with the
        valves at that case's fixed point (:func:`hisopt.studies.damper_valves.mode_damping`)
    build : pd.DataFrame
        every buildability rule, whether or not the problem enforces it: where it binds, its
        value, limit, usage and margin (:func:`hisopt.studies.buildability.rule_sheet`)
    verified : VerifiedDesign | None
        its verification in the time domain (``RUN_DIR/verify-N``,
        :mod:`hisopt.studies.verified`); None when not verified
    verify_hint : str
        why it is not verified and the command that would verify it (``""`` for a sheet not
        of a run)
    """

    problem: Problem
    design: int
    source: str
    parts: pd.DataFrame
    quantities: pd.DataFrame
    envelope: pd.DataFrame
    modes: pd.DataFrame
    valves: pd.DataFrame = field(default_factory=pd.DataFrame)
    valve_cases: pd.DataFrame = field(default_factory=pd.DataFrame)
    valve_modes: pd.DataFrame = field(default_factory=pd.DataFrame)
    build: pd.DataFrame = field(default_factory=pd.DataFrame)
    verified: VerifiedDesign | None = None
    verify_hint: str = ""

    def problem_data(self) -> dict[str, Any]:
        """The problem file of the design (its ``[his]`` values are the design's), as TOML data:
        the specification without empty values (TOML has no null)."""
        return without_none(self.problem.spec.model_dump(mode="json", by_alias=True))


def without_none(data: Any) -> Any:
    """``data`` (nested dicts and lists) without its None values: what TOML can hold."""
    if isinstance(data, dict):
        return {k: without_none(v) for k, v in data.items() if v is not None}
    if isinstance(data, list):
        return [without_none(v) for v in data]
    return data


def design_sheet(problem: Problem, x: np.ndarray, design: int, source: str, run_dir: str | Path | None = None) -> DesignSheet:
    """The sheet of design ``x`` (``(n_var,)`` [SI]) of ``problem``, row ``design`` of
    ``source``; with ``run_dir``, its verification in the time domain if the run holds one
    (:func:`verification_of`).

    Raises
    ------
    RunError
        the run's ``verify-N`` folder holds a malformed summary or table.
    """
    sheet_problem = problem.replace_values(dict(zip(problem.variable_names, (float(v) for v in x), strict=True)))
    baseline = sheet_problem.baseline[None, :]
    quantities = sheet_problem.evaluate(baseline, log=False)
    modes = modal_analysis(sheet_problem)[list(MODE_COLUMNS)]
    modes.attrs = {"units": {"mode": "-", "motion": "-", "frequency_hz": "Hz", "damping_ratio": "-"}}
    build = rule_sheet(load_case_rules(sheet_problem, baseline))
    verified, hint = verification_of(run_dir, design, list(problem.variable_names), x) if run_dir is not None else (None, "")
    parts = parts_table(sheet_problem)
    envelope = envelope_table(sheet_problem)
    sheet = DesignSheet(sheet_problem, design, source, parts, quantities, envelope, modes, build=build, verified=verified, verify_hint=hint)
    if not damper_valves.has_damper_valves(sheet_problem):
        return sheet
    cases = damper_valves.load_case_valves(sheet_problem, baseline)
    table = damper_valves.valve_table(cases)
    per_case = table.drop(columns=["design", "converged"])
    per_case.attrs = {"units": {k: v for k, v in table.attrs["units"].items() if k in per_case.columns}}
    return replace(sheet, valves=damper_valves.valve_settings(cases[0]), valve_cases=per_case, valve_modes=damper_valves.mode_damping(cases))


def verification_of(run_dir: str | Path, design: int, names: list[str], x: np.ndarray) -> tuple[VerifiedDesign | None, str]:
    """``(verification, "")`` of front row ``design`` (values ``x`` [SI] of variables
    ``names``) when ``RUN_DIR/verify-N`` holds one of this design; else ``(None, why not and
    the command that verifies it)``.

    Raises
    ------
    RunError
        the folder holds a malformed summary or table (:func:`hisopt.studies.verified.read_verification`).
    """
    folder = verify_folder(run_dir, design)
    command = f"hisopt verify {run_dir} --design {design}"
    if not (folder / VERIFY_JSON).is_file():
        return None, f"not verified: run {command}"
    found = read_verification(folder)
    if found.summary["row"] != design or not same_design(found.summary["values"], names, x):
        return None, f"not verified: {folder} holds the verification of another design (a front before the run was resumed); run {command}"
    return found, ""


def parts_table(problem: Problem) -> pd.DataFrame:
    """[SI] The bill of parts and settings of ``problem``'s baseline design: per axle its
    cylinders' bore and rod (``dA`` and ``lam`` for a problem posed in the paper's terms:
    the sizes they make), the accumulators (nominal volume, precharge at the charge
    temperature, gas separator and rating), the charge (oil fill and the static pressure it
    gives at the charge temperature), the valves (a physical damper valve's settings are in
    :attr:`DesignSheet.valves`) and the pipes."""
    spec = problem.spec
    his = problem.model(problem.baseline[None, :]).his
    assert his is not None  # a model with HIS
    params = his.params
    rows: list[tuple[str, float, str, str]] = []
    for axle, suffix in (("front", ""), ("rear", "_rear")):
        d_a, lam = float(np.ravel(params[f"dA{suffix}"])[0]), float(np.ravel(params[f"lam{suffix}"])[0])
        sized = params.get(f"bore{suffix}") is not None
        # the given sizes as they are; else the ones dA and lam make
        bore, rod = (float(np.ravel(params[f"{part}{suffix}"])[0]) for part in ("bore", "rod")) if sized else laws.bore_and_rod(d_a, lam)
        note = "" if sized else "the size dA and lam make (not a listed part)"
        top, bottom = laws.cylinder_areas(d_a, lam)
        rows += [
            (f"{axle} cylinder bore", bore, "m", note),
            (f"{axle} piston rod", rod, "m", note),
            (f"{axle} bottom chamber area (bore)", float(bottom), "m^2", ""),
            (f"{axle} top chamber area (annulus)", float(top), "m^2", ""),
        ]
    rating = float(params["pressure_rating"])
    separator = spec.his.separator if spec.his.pressure_rating is None else f"{spec.his.separator}, rating given"
    for k, e, _ in his.network.accumulators():
        name = his.network.layout.circuits[his.network.elements[k][0]].name
        rows += [
            (f"accumulator {name}: nominal volume", float(np.ravel(resolve(e.volume, params))[0]), "m^3", ""),
            (f"accumulator {name}: precharge (gauge, at the charge temperature)", float(np.ravel(resolve(e.precharge, params))[0]), "Pa", ""),
            (f"accumulator {name}: pressure rating (working over precharge, gauge)", rating, "-", separator),
        ]
    if spec.his.charge is not None:
        charge = spec.his.charge
        rows += [
            ("charge: gas share of each accumulator at charge", charge.gas_fraction, "-", ""),
            ("charge: oil per circuit outside chambers and pipes", charge.oil_volume, "m^3", ""),
            ("charge: temperature", charge.temperature, "K", ""),
        ]
        pressure = np.ravel(his.static_pressure) if his.static_pressure is not None else np.empty(0)
        for c, value in enumerate(pressure):
            rows.append((f"charge: circuit {his.network.layout.circuits[c].name} static pressure, unladen (absolute)", float(value), "Pa", ""))
    for k, valve, _ in his.network.valves():
        if isinstance(valve, DamperValve):
            continue  # a physical valve has its own section: its settings, not one coefficient
        rows.append((f"valve {valve.a} - {valve.b}: coefficient", float(np.ravel(his.values.resistance[k])[0]), "Pa s m^-3", ""))
    if spec.his.pipes is not None:
        for what in ("diameter", "length front", "length rear"):
            rows.append((f"pipe {what}", float(np.ravel(params[f"pipe_{what.replace(' ', '_')}"])[0]), "m", ""))
    return pd.DataFrame(rows, columns=["item", "value", "unit", "note"])


def write_problem(sheet: DesignSheet, path: Path) -> None:
    """The sheet's problem file (TOML): ``hisopt evaluate`` on it gives the sheet's quantities."""
    import tomli_w

    path.write_text(tomli_w.dumps(sheet.problem_data()), encoding="utf-8")
