"""hisopt: design optimiser for vehicles with roll-plane hydraulically interconnected suspension.

Public API (docs/model.md §8): the names of ``hisopt.__all__``, plus the documented
sub-packages :mod:`hisopt.road` (road inputs), :mod:`hisopt.plotting` (theme and figures of
data) and :mod:`hisopt.report` (layout schematics and reports). Everything else is internal
and may move. ::

    import hisopt
    problem = hisopt.load_problem("problems/roll_plane_his.toml")
    df = problem.evaluate(X)
    modes = hisopt.modal_analysis(problem, design, his=True)
    spread = hisopt.tolerance(problem, design, n_samples=100_000)
    run = hisopt.optimize(problem, ...)
    table = hisopt.compare_layouts(problem, layouts="axle_roll,pitch_plane", seeds="1-3", out="runs/layouts")
    found = hisopt.run_synthesis(problem, max_elements=8, chambers="front", out="runs/synthesis")
"""

from __future__ import annotations

import sys
import warnings
from importlib import import_module
from importlib.abc import Loader, MetaPathFinder
from importlib.machinery import ModuleSpec
from importlib.util import spec_from_loader
from types import ModuleType
from typing import TYPE_CHECKING, Any

from hisopt.errors import ConfigError, HisoptError, ModelError, PlausibilityWarning, ProblemFileNotFoundError, RunError
from hisopt.version import __version__ as __version__

if TYPE_CHECKING:
    from hisopt.coupled.modal import modal_analysis, track_modes
    from hisopt.coupled.model import CoupledModel
    from hisopt.evaluation.evaluate import Evaluator, roll_gradient
    from hisopt.evaluation.parallel import open_backend
    from hisopt.hydraulics.catalogue import CATALOGUE_NAMES, catalogue, his_parameter_values
    from hisopt.io import read_csv
    from hisopt.optim.gradient.refine import refine_front, refine_run
    from hisopt.optim.results import OptimizationResult
    from hisopt.optim.run import optimize, resume
    from hisopt.problem import Problem, load_problem, problem_from_dict
    from hisopt.simulation.droptest import drop_table, measured_drop_test, response_sensors, run_drop_tests, simulate_drop, spectra_figure
    from hisopt.simulation.timedomain import simulate
    from hisopt.specification.design_space import DesignSpace
    from hisopt.specification.validation import admissible
    from hisopt.studies.layout_study import compare_layouts, run_layout_study
    from hisopt.studies.screening import STROKE_PATTERNS, mode_stiffness
    from hisopt.studies.spectra import response_spectra
    from hisopt.studies.sweeps import regions, sweep
    from hisopt.studies.synthesis import run_synthesis
    from hisopt.studies.uncertainty import SensitivityResult, ToleranceResult, sensitivity, tolerance, uncertain_inputs
    from hisopt.units import display_frame, format_quantity

# The model pulls in scipy and pandas, optimisation pymoo, figures plotly: import them only
# when a name is asked for, so that `import hisopt` (and `hisopt --help`) stays light.
_LAZY = {
    "Problem": "hisopt.problem",
    "load_problem": "hisopt.problem",
    "problem_from_dict": "hisopt.problem",
    "DesignSpace": "hisopt.specification.design_space",
    "admissible": "hisopt.specification.validation",
    "CoupledModel": "hisopt.coupled.model",
    "modal_analysis": "hisopt.coupled.modal",
    "track_modes": "hisopt.coupled.modal",
    "CATALOGUE_NAMES": "hisopt.hydraulics.catalogue",
    "catalogue": "hisopt.hydraulics.catalogue",
    "his_parameter_values": "hisopt.hydraulics.catalogue",
    "Evaluator": "hisopt.evaluation.evaluate",
    "roll_gradient": "hisopt.evaluation.evaluate",
    "open_backend": "hisopt.evaluation.parallel",
    "simulate": "hisopt.simulation.timedomain",
    "simulate_drop": "hisopt.simulation.droptest",
    "response_sensors": "hisopt.simulation.droptest",
    "run_drop_tests": "hisopt.simulation.droptest",
    "measured_drop_test": "hisopt.simulation.droptest",
    "drop_table": "hisopt.simulation.droptest",
    "spectra_figure": "hisopt.simulation.droptest",
    "OptimizationResult": "hisopt.optim.results",
    "optimize": "hisopt.optim.run",
    "resume": "hisopt.optim.run",
    "refine_front": "hisopt.optim.gradient.refine",
    "refine_run": "hisopt.optim.gradient.refine",
    "sweep": "hisopt.studies.sweeps",
    "regions": "hisopt.studies.sweeps",
    "response_spectra": "hisopt.studies.spectra",
    "STROKE_PATTERNS": "hisopt.studies.screening",
    "mode_stiffness": "hisopt.studies.screening",
    "compare_layouts": "hisopt.studies.layout_study",
    "run_layout_study": "hisopt.studies.layout_study",
    "run_synthesis": "hisopt.studies.synthesis",
    "sensitivity": "hisopt.studies.uncertainty",
    "tolerance": "hisopt.studies.uncertainty",
    "uncertain_inputs": "hisopt.studies.uncertainty",
    "SensitivityResult": "hisopt.studies.uncertainty",
    "ToleranceResult": "hisopt.studies.uncertainty",
    "display_frame": "hisopt.units",
    "format_quantity": "hisopt.units",
    "read_csv": "hisopt.io",
}

__all__ = [
    "CATALOGUE_NAMES",
    "ConfigError",
    "CoupledModel",
    "DesignSpace",
    "Evaluator",
    "HisoptError",
    "ModelError",
    "OptimizationResult",
    "PlausibilityWarning",
    "Problem",
    "ProblemFileNotFoundError",
    "RunError",
    "STROKE_PATTERNS",
    "SensitivityResult",
    "ToleranceResult",
    "admissible",
    "catalogue",
    "compare_layouts",
    "display_frame",
    "drop_table",
    "format_quantity",
    "his_parameter_values",
    "load_problem",
    "measured_drop_test",
    "modal_analysis",
    "mode_stiffness",
    "open_backend",
    "optimize",
    "problem_from_dict",
    "read_csv",
    "refine_front",
    "refine_run",
    "regions",
    "response_sensors",
    "response_spectra",
    "resume",
    "roll_gradient",
    "run_drop_tests",
    "run_layout_study",
    "run_synthesis",
    "sensitivity",
    "simulate",
    "simulate_drop",
    "spectra_figure",
    "sweep",
    "tolerance",
    "track_modes",
    "uncertain_inputs",
]

_DOCUMENTED_SUBPACKAGES = ("hisopt.plotting", "hisopt.report", "hisopt.road")
"""Sub-packages whose ``__all__`` is public API too (docs/api/index.rst)."""


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        value = getattr(import_module(_LAZY[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'hisopt' has no attribute {name!r}")


def __dir__() -> list[str]:
    # the public names only (tab completion shows the API, not the helpers of this file)
    return sorted({*__all__, "__version__", *(name.rpartition(".")[2] for name in _DOCUMENTED_SUBPACKAGES)})


# Module paths that the documentation named before the package was sorted into folders
# (issue 23): they keep working, as aliases of the new modules, for one release.
_MOVED = {
    "hisopt.cli_compare": "hisopt.cli.compare",
    "hisopt.cli_usage": "hisopt.cli.usage",
    "hisopt.console": "hisopt.cli.console",
    "hisopt.report.theme": "hisopt.plotting.theme",
    "hisopt.report.axes": "hisopt.plotting.axes",
    "hisopt.report.figures": "hisopt.plotting.figures",
    "hisopt.sweeps": "hisopt.studies.sweeps",
    "hisopt.spectra": "hisopt.studies.spectra",
    "hisopt.layouts": "hisopt.studies.screening",
    "hisopt.optim.layout_study": "hisopt.studies.layout_study",
    "hisopt.optim.layout_cases": "hisopt.studies.layout_cases",
    "hisopt.optim.layout_metrics": "hisopt.studies.layout_metrics",
    "hisopt.optim.layout_tables": "hisopt.studies.layout_tables",
    "hisopt.optim.layout_folder": "hisopt.studies.layout_folder",
    "hisopt.optim.casadi_model": "hisopt.optim.gradient.casadi_model",
    "hisopt.optim.refine": "hisopt.optim.gradient.refine",
    "hisopt.optim.asf_nlp": "hisopt.optim.gradient.asf_nlp",
    "hisopt.optim.transient_callback": "hisopt.optim.gradient.transient_callback",
    "hisopt.timedomain": "hisopt.simulation.timedomain",
    "hisopt.nonlinear_model": "hisopt.simulation.nonlinear_model",
    "hisopt.droptest": "hisopt.simulation.droptest",
    "hisopt.identification": "hisopt.simulation.identification",
    "hisopt.evaluate": "hisopt.evaluation.evaluate",
    "hisopt.kernels": "hisopt.evaluation.kernels",
    "hisopt.quadrature": "hisopt.evaluation.quadrature",
    "hisopt.pole_residue": "hisopt.evaluation.pole_residue",
    "hisopt.channels": "hisopt.evaluation.channels",
    "hisopt.transient": "hisopt.evaluation.transient",
    "hisopt.scenario_evaluator": "hisopt.evaluation.scenarios",
    "hisopt.reference": "hisopt.evaluation.reference",
    "hisopt.parallel": "hisopt.evaluation.parallel",
    "hisopt.peaks": "hisopt.evaluation.peaks",
    "hisopt.symmetry": "hisopt.evaluation.symmetry",
    "hisopt.psd": "hisopt.evaluation.psd",
    "hisopt.config": "hisopt.specification.config",
    "hisopt.design_space": "hisopt.specification.design_space",
    "hisopt.designs": "hisopt.specification.designs",
    "hisopt.validation": "hisopt.specification.validation",
    "hisopt.problem_units": "hisopt.specification.problem_units",
    "hisopt.model": "hisopt.coupled.model",
    "hisopt.modal": "hisopt.coupled.modal",
    "hisopt.response": "hisopt.coupled.response",
    "hisopt.payload": "hisopt.coupled.payload",
}
# (The old module ``hisopt.cli`` is now the package of that name, which still exports ``app`` and ``main``.)


class _MovedLoader(Loader):
    """Serves an old module path as the new module itself (one object, so ``is`` holds)."""

    def __init__(self, old: str, new: str) -> None:
        self.old, self.new = old, new
        self.spec: ModuleSpec | None = None

    def create_module(self, spec: ModuleSpec) -> ModuleType:
        module = import_module(self.new)
        self.spec = module.__spec__
        return module

    def exec_module(self, module: ModuleType) -> None:
        module.__spec__ = self.spec  # the import system set the old name's spec on the shared module
        # stacklevel 2 skips the import machinery's frames: the warning names the importing line.
        msg = f"{self.old} is deprecated and will be removed in the next release: import {self.new} (or the public names of hisopt)"
        warnings.warn(msg, DeprecationWarning, stacklevel=2)


class _MovedFinder(MetaPathFinder):
    """Finds the old module paths of :data:`_MOVED` (after every other finder has failed)."""

    def find_spec(self, fullname: str, path: Any = None, target: ModuleType | None = None) -> ModuleSpec | None:
        new = _MOVED.get(fullname)
        return None if new is None else spec_from_loader(fullname, _MovedLoader(fullname, new))


if not any(type(f).__name__ == "_MovedFinder" for f in sys.meta_path):
    sys.meta_path.append(_MovedFinder())
