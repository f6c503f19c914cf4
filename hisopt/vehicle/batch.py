"""A batch of cars: every :class:`VehicleParams` field as an array over designs or samples
(docs/model.md §2.6), for evaluating many cars that differ in their masses, springs or
geometry in one vectorised call, as the HIS parameters already are.

:mod:`hisopt.vehicle.full_car` builds its matrices from one car or a batch with the same
operations, so a batch's row is its car's matrix to the last bit. A batch is made from a
validated car and the values that vary (:meth:`VehicleBatch.of`); the rows that break a
field's rule are found by :meth:`VehicleBatch.breaks`, one message per row, so that a sample
set can flag them instead of stopping.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields

import numpy as np
from numpy.typing import ArrayLike

from hisopt.errors import ConfigError
from hisopt.vehicle.parameters import VehicleParams


@dataclass(frozen=True)
class VehicleBatch:
    """The fields of :class:`VehicleParams`, each an array of one batch shape ``B``
    (units and meaning as there)."""

    m_s: np.ndarray
    I_x: np.ndarray
    I_y: np.ndarray
    m_uf: np.ndarray
    m_ur: np.ndarray
    k_sf: np.ndarray
    k_sr: np.ndarray
    c_sf: np.ndarray
    c_sr: np.ndarray
    k_arb_f: np.ndarray
    k_arb_r: np.ndarray
    k_tf: np.ndarray
    k_tr: np.ndarray
    c_tf: np.ndarray
    c_tr: np.ndarray
    t_f: np.ndarray
    t_r: np.ndarray
    l_f: np.ndarray
    l_r: np.ndarray
    h_0s: np.ndarray
    y_cg: np.ndarray
    h_cg: np.ndarray
    body_half_width: np.ndarray
    overhang_f: np.ndarray
    overhang_r: np.ndarray

    @classmethod
    def of(cls, vehicle: VehicleParams, values: Mapping[str, ArrayLike]) -> VehicleBatch:
        """``vehicle`` with the fields in ``values`` varied (arrays that broadcast to one
        batch shape, SI units); the other fields repeated.

        Raises
        ------
        ConfigError
            A name that is no field of the car.
        """
        unknown = sorted(set(values) - set(VehicleParams.model_fields))
        if unknown:
            raise ConfigError(f"unknown vehicle parameter {unknown[0]!r}; expected one of {', '.join(VehicleParams.model_fields)}", key=f"vehicle.{unknown[0]}")
        arrays = np.broadcast_arrays(*(np.asarray(values.get(f.name, getattr(vehicle, f.name)), dtype=float) for f in fields(cls)))
        return cls(*(np.array(a) for a in arrays))  # owned copies: a batch does not alias its inputs

    @property
    def shape(self) -> tuple[int, ...]:
        """[-] The batch shape ``B``."""
        return self.m_s.shape

    @property
    def wheelbase(self) -> np.ndarray:
        """[m] front-to-rear axle distance, shape ``B``."""
        return self.l_f + self.l_r

    @property
    def total_mass(self) -> np.ndarray:
        """[kg] sprung plus unsprung mass, shape ``B``."""
        return self.m_s + 2.0 * (self.m_uf + self.m_ur)

    def rows(self, rows: np.ndarray) -> VehicleBatch:
        """The cars ``rows`` (indices or a boolean mask of the batch's first axis)."""
        return VehicleBatch(*(np.asarray(getattr(self, f.name))[rows] for f in fields(self)))

    def car(self, index: int | tuple[int, ...]) -> VehicleParams:
        """One car of the batch, validated.

        Raises
        ------
        pydantic.ValidationError
            The car breaks a field's rule (:meth:`breaks` says which).
        """
        return VehicleParams(**{f.name: float(getattr(self, f.name)[index]) for f in fields(self)})

    def breaks(self) -> np.ndarray:
        """[-] Per car, the first rule it breaks as ``"m_s = -3 breaks m_s > 0"``, or ``""``
        (the rules of :class:`VehicleParams`: its fields' bounds, finite values, the CG
        inside the track); an object array of shape ``B``."""
        out = np.full(self.shape, "", dtype=object)
        for f in reversed(fields(self)):  # the first field's message wins
            value = getattr(self, f.name)
            for rule in VehicleParams.model_fields[f.name].metadata:  # pydantic's Gt(gt=0) and Ge(ge=0)
                if getattr(rule, "gt", None) is not None:
                    bad, text = ~(value > rule.gt), f"{f.name} > {rule.gt:g}"
                elif getattr(rule, "ge", None) is not None:
                    bad, text = ~(value >= rule.ge), f"{f.name} >= {rule.ge:g}"
                else:
                    continue
                out[bad] = [f"{f.name} = {v:g} breaks {text}" for v in value[bad]]
            bad = ~np.isfinite(value)
            out[bad] = [f"{f.name} = {v:g} is not a finite number" for v in value[bad]]
        half = np.minimum(self.t_f, self.t_r)
        outside = (out == "") & ~(np.abs(self.y_cg) < half)
        out[outside] = [f"y_cg = {y:g} m puts the CG outside the track (|y_cg| < {h:g} m)" for y, h in zip(self.y_cg[outside], half[outside], strict=True)]
        return out
