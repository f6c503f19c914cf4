"""Figures and reports (plotly); imported lazily so the CLI starts fast.

Public API (documented sub-package): the names of ``__all__``, imported when first used.
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from hisopt.report.decision_page import DecisionRoom, decision_room
    from hisopt.report.html import build_report
    from hisopt.report.layout_report import attainment_figure, curve_figure, fronts_figure, write_layout_report
    from hisopt.report.schematic import layout_schematic

_LAZY = {
    "DecisionRoom": "hisopt.report.decision_page",
    "decision_room": "hisopt.report.decision_page",
    "build_report": "hisopt.report.html",
    "attainment_figure": "hisopt.report.layout_report",
    "curve_figure": "hisopt.report.layout_report",
    "fronts_figure": "hisopt.report.layout_report",
    "write_layout_report": "hisopt.report.layout_report",
    "layout_schematic": "hisopt.report.schematic",
}

__all__ = [
    "DecisionRoom",
    "attainment_figure",
    "build_report",
    "curve_figure",
    "decision_room",
    "fronts_figure",
    "layout_schematic",
    "write_layout_report",
]


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        return getattr(import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'hisopt.report' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
