"""Problem-file values with units, converted to SI before validation (docs/input.md, "Units").

``p0 = "2.5 MPa"``, ``speed = "72 km/h"``, ``limit = "1.5 deg"``: every string holding a
number and a unit, where the problem file expects a number of a known unit, becomes that
number in SI (:func:`hisopt.quantities.to_si`). The unit of each key comes from:

- the field's declared SI unit (:func:`hisopt.quantities.field_unit`) for the tables of
  :class:`~hisopt.specification.config.ProblemSpec` (vehicle, his, pipes, fluid, road, band, comfort,
  handling, payload, scenarios, robust);
- the parameter a ``[variables]`` entry names, for its ``lower`` and ``upper``, and a
  ``[his.parameters]`` entry's own name (:func:`hisopt.hydraulics.catalogue.parameter_unit`);
- the element field, for a number in a custom layout's ``[[his.circuits]]`` elements;
- the constrained quantity (:data:`hisopt.metrics.METRICS`), for a ``[[constraints]]`` limit.

Everything else is left to the strict validation as it is: a bare number is SI, a string
without a number (or without a unit) is still "expected a valid number", a boolean is
still not a number.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from hisopt.quantities import check_si_label, field_unit, has_unit, split_quantity, to_si


def convert_problem_units(data: Mapping[str, Any], source: str, spec: type) -> dict[str, Any]:
    """A copy of problem-file data (for the pydantic model ``spec``,
    :class:`~hisopt.specification.config.ProblemSpec`) with every ``"<number> <unit>"`` value in SI.

    Raises
    ------
    ConfigError
        A unit that is unknown or measures another kind of quantity (naming ``source``, the
        key and the expected kind).
    """
    from hisopt.hydraulics.catalogue import parameter_unit
    from hisopt.metrics import METRICS
    from hisopt.robust import quantity_of

    out = _convert_fields(spec, data, "", source)
    his = out.get("his")
    uses = _raw_parameter_uses(his) if isinstance(his, dict) else {}

    def convert(table: Any, keys: tuple[str, ...], unit: str | None, prefix: str) -> Any:
        if unit is None or not isinstance(table, dict):
            return table
        return {k: to_si(v, unit, file=source, key=f"{prefix}.{k}") if k in keys and has_unit(v) else v for k, v in table.items()}

    if isinstance(his, dict):
        params = his.get("parameters")
        if isinstance(params, dict):
            his["parameters"] = {k: _maybe(v, parameter_unit(str(k), uses), source, f"his.parameters.{k}") for k, v in params.items()}
        circuits = his.get("circuits")
        if isinstance(circuits, list):
            his["circuits"] = [_convert_circuit(c, i, source) for i, c in enumerate(circuits)]
    variables = out.get("variables")
    if isinstance(variables, dict):
        converted = {}
        for name, table in variables.items():
            unit = parameter_unit(str(name), uses)
            converted[name] = convert(table, ("lower", "upper"), unit, f"variables.{name}")
            if unit is not None and isinstance(table, dict):
                converted[name] = _choices_in_si(converted[name], unit, source, f"variables.{name}")
            label = table.get("unit") if isinstance(table, dict) else None
            if unit is not None and isinstance(label, str):
                check_si_label(label, unit, file=source, key=f"variables.{name}.unit")
        out["variables"] = converted
    constraints = out.get("constraints")
    if isinstance(constraints, list):
        out["constraints"] = [convert(c, ("limit",), _metric_unit(c, METRICS, quantity_of), f"constraints.{i}") for i, c in enumerate(constraints)]
    return out


def _choices_in_si(table: dict[str, Any], unit: str, source: str, key: str) -> dict[str, Any]:
    """A choice variable's listed values in SI: ``choices`` as written (``"50 mm"``), or its
    ``catalogue``'s (:func:`hisopt.specification.catalogues.resolve_catalogue`)."""
    from pathlib import Path

    from hisopt.specification.catalogues import resolve_catalogue

    choices = table.get("choices")
    if isinstance(choices, list):
        table = table | {"choices": [_maybe(v, unit, source, f"{key}.choices.{i}") for i, v in enumerate(choices)]}
    folder = Path(source).parent if Path(source).is_file() else None
    return resolve_catalogue(table, unit, folder, file=source, key=key)


def _maybe(value: Any, unit: str | None, source: str, key: str) -> Any:
    return to_si(value, unit, file=source, key=key) if unit is not None and has_unit(value) else value


def _metric_unit(table: Any, metrics: Mapping[str, Any], quantity_of: Callable[[str], str]) -> str | None:
    name = table.get("name") if isinstance(table, dict) else None
    return metrics[quantity_of(name)].unit if isinstance(name, str) and quantity_of(name) in metrics else None


def _convert_fields(model: Any, data: Any, prefix: str, source: str) -> Any:
    """``data`` for ``model`` with its unit-declaring fields converted, nested tables too."""
    if not isinstance(data, dict):
        return data
    fields = model.model_fields
    out = dict(data)
    for key, value in data.items():
        info = fields.get(key) or next((f for f in fields.values() if f.alias == key), None)
        if info is None:
            continue  # an unknown key: validation names it
        where = f"{prefix}{key}"
        unit = field_unit(model, key)
        if unit is not None:
            out[key] = _maybe(value, unit, source, where)
            continue
        inner, container = _inner_model(info.annotation)
        if inner is None:
            continue
        if container is list and isinstance(value, list):
            out[key] = [_convert_fields(inner, v, f"{where}.{i}.", source) for i, v in enumerate(value)]
        elif container is dict and isinstance(value, dict):
            out[key] = {k: _convert_fields(inner, v, f"{where}.{k}.", source) for k, v in value.items()}
        elif container is None:
            out[key] = _convert_fields(inner, value, f"{where}.", source)
    return out


def _inner_model(annotation: Any) -> tuple[Any, Any]:
    """``(Model, None)`` for ``Model | None``, ``(Model, list)`` for ``list[Model]`` (also
    optional), ``(Model, dict)`` for ``dict[str, Model]``; ``(None, None)`` otherwise."""
    args = [a for a in getattr(annotation, "__args__", ()) if a is not type(None)]
    origin = getattr(annotation, "__origin__", None)
    if origin in (list, dict):
        inner = args[-1] if args else None
        return (inner, origin) if hasattr(inner, "model_fields") else (None, None)
    if hasattr(annotation, "model_fields"):
        return annotation, None
    if len(args) == 1:
        return _inner_model(args[0])
    return None, None


def _raw_parameter_uses(his: Mapping[str, Any]) -> dict[str, list[tuple[type, str]]]:
    """Which element fields read each parameter name, from the unvalidated ``[his]`` table:
    the catalogue layout it names, or the elements of its ``[[his.circuits]]``."""
    from hisopt.hydraulics.catalogue import CUSTOM, catalogue
    from hisopt.hydraulics.layout import PARAMETER_FIELDS, parameter_uses
    from hisopt.hydraulics.layout_file import ELEMENT_TYPES

    layout = his.get("layout", "roll_plane")
    if layout != CUSTOM:
        entry = catalogue().get(layout) if isinstance(layout, str) else None
        return parameter_uses(entry.base) if entry is not None else {}
    uses: dict[str, list[tuple[type, str]]] = {}
    for circuit in his.get("circuits") or []:
        for element in (circuit.get("elements") or []) if isinstance(circuit, dict) else []:
            kind = element.get("type") if isinstance(element, dict) else None
            cls = ELEMENT_TYPES.get(kind) if isinstance(kind, str) else None
            if cls is None:
                continue
            for name in PARAMETER_FIELDS[cls]:
                ref = element.get(name)
                if isinstance(ref, str) and split_quantity(ref) is None:  # a parameter's name
                    uses.setdefault(ref, []).append((cls, name))
    return uses


def _convert_circuit(circuit: Any, index: int, source: str) -> Any:
    """A ``[[his.circuits]]`` table with its elements' numbers with units in SI (a parameter's
    name does not start with a number)."""
    from hisopt.hydraulics.layout import PARAMETER_FIELDS
    from hisopt.hydraulics.layout_file import ELEMENT_TYPES

    if not isinstance(circuit, dict) or not isinstance(circuit.get("elements"), list):
        return circuit
    elements = []
    for j, element in enumerate(circuit["elements"]):
        kind = element.get("type") if isinstance(element, dict) else None
        cls = ELEMENT_TYPES.get(kind) if isinstance(kind, str) else None
        if cls is not None:
            element = dict(element)
            for name in PARAMETER_FIELDS[cls]:
                if has_unit(element.get(name)):
                    element[name] = to_si(element[name], str(field_unit(cls, name)), file=source, key=f"his.circuits.{index}.elements.{j}.{name}")
        elements.append(element)
    return {**circuit, "elements": elements}
