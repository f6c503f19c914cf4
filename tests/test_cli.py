"""CLI smoke tests through the real entry point (exit codes, output)."""

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import hisopt
from hisopt.io import read_csv
from tests.conftest import DEFAULT_PROBLEM


def run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "hisopt", *args], capture_output=True, text=True, timeout=300)


def test_modes_prints_table_with_and_without_his():
    out = run("modes", str(DEFAULT_PROBLEM))
    assert out.returncode == 0, out.stderr
    for word in ("bounce", "roll", "pitch", "front_axle_hop", "rear_axle_tramp", "f ref [Hz]", "f HIS [Hz]", "zeta HIS [-]", "change [%]"):
        assert word in out.stdout
    assert "wheel_hop_fl/fr/rl/rr = front_axle_hop, front_axle_tramp, rear_axle_hop, rear_axle_tramp" in out.stdout
    assert "2.744" in out.stdout  # baseline roll frequency with HIS


def test_modes_compares_the_same_mode_without_and_with_his():
    # issue 12: at p0 = 3 MPa the unchanged 11.08 Hz wheel warp had a different name with HIS
    # than without, so the change column compared different modes
    out = run("modes", str(DEFAULT_PROBLEM), "--set", "p0=3e6")
    assert out.returncode == 0, out.stderr
    row = next(line for line in out.stdout.splitlines() if "rear_axle_tramp" in line)
    cells = [c.strip() for c in row.strip("│ ").split("│")]
    assert cells[2] == cells[4] == "11.08" and cells[6] == "+0.0", row


def test_modes_set_override_changes_result():
    out = run("modes", str(DEFAULT_PROBLEM), "--set", "p0=4e6")
    assert out.returncode == 0, out.stderr
    assert "p0 = 4 MPa" in out.stdout and "dA = 10 cm^2" in out.stdout  # the design, in engineering units


def test_user_errors_exit_2_without_traceback(tmp_path):
    out = run("modes", str(tmp_path / "missing.toml"))
    assert out.returncode == 2
    assert "missing.toml" in out.stderr and "Traceback" not in out.stderr
    out = run("modes", str(DEFAULT_PROBLEM), "--set", "nonsense")
    assert out.returncode == 2 and "KEY=VALUE" in out.stderr


def test_evaluate_baseline_and_designs_file(tmp_path):
    out = run("evaluate", str(DEFAULT_PROBLEM))
    assert out.returncode == 0, out.stderr
    assert "0.5534" in out.stdout  # docs/model.md §7.1: 0.5534
    for shown in ("sigma_aw [m/s^2]", "p0 [MPa]", "dA [cm^2]", "Rv [MPa s/m^3]", "max_roll_psd [rad^2/Hz]", "8.467e-5"):
        assert shown in out.stdout  # units on every row, engineering values
    designs = tmp_path / "designs.csv"
    designs.write_text("p0,dA,lam,Rv\n2e6,1e-3,0.5,8e5\n0,1e-4,0.1,0\n")
    results = tmp_path / "results.csv"
    out = run("evaluate", str(DEFAULT_PROBLEM), "--designs", str(designs), "--out", str(results))
    assert out.returncode == 0, out.stderr

    df = read_csv(results)
    assert list(df.columns) == ["p0", "dA", "lam", "Rv", "sigma_aw", "max_roll_psd", "max_stroke_psd", "max_tire_load_psd", "feasible", "status", "reason"]
    assert abs(df.loc[1, "sigma_aw"] / 0.4599 - 1) < 5e-3
    assert df.attrs["units"] == {
        "p0": "Pa", "dA": "m^2", "lam": "-", "Rv": "Pa s m^-3", "sigma_aw": "m/s^2", "max_roll_psd": "rad^2/Hz",
        "max_stroke_psd": "m^2/Hz", "max_tire_load_psd": "N^2/Hz", "feasible": "-", "status": "-", "reason": "-",
    }  # fmt: skip
    assert results.read_text().splitlines()[1].startswith("[Pa],[m^2],[-],[Pa s m^-3],[m/s^2]")
    # The results file is a designs file again (its units row is skipped), with the same results.
    again = tmp_path / "again.csv"
    out = run("evaluate", str(DEFAULT_PROBLEM), "--designs", str(results), "--out", str(again))
    assert out.returncode == 0, out.stderr
    assert read_csv(again).equals(df)


def test_evaluate_bad_designs_file_is_a_user_error(tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("p0,dA\n1,2\n")
    out = run("evaluate", str(DEFAULT_PROBLEM), "--designs", str(bad))
    assert out.returncode == 2
    assert "bad.csv" in out.stderr and "'lam'" in out.stderr and "Traceback" not in out.stderr


def test_response_writes_csv_and_offline_html(tmp_path):
    out = run("response", str(DEFAULT_PROBLEM), "--out", str(tmp_path / "resp"))
    assert out.returncode == 0, out.stderr

    df = read_csv(tmp_path / "resp" / "response.csv")
    for col in ("f_hz", "acc_z_his", "acc_z_ref", "acc_roll_his", "acc_pitch_ref", "tire_load_fl_his"):
        assert col in df
    units = df.attrs["units"]
    assert units["f_hz"] == "Hz" and units["acc_z_his"] == "(m/s^2)^2/Hz" and units["tire_load_fl_ref"] == "N^2/Hz"
    assert units["acc_roll_ref"] == "(rad/s^2)^2/Hz" and set(units) == set(df.columns)
    # The HIS stiffens bounce: the body's vertical-acceleration peak moves up in frequency;
    # at the lowest frequency the body follows the road with or without HIS.
    body = df[df["f_hz"] < 5]
    assert body.loc[body["acc_z_his"].idxmax(), "f_hz"] > body.loc[body["acc_z_ref"].idxmax(), "f_hz"]
    assert abs(df.loc[0, "acc_z_his"] / df.loc[0, "acc_z_ref"] - 1) < 0.25
    html = (tmp_path / "resp" / "response.html").read_text()
    assert "plotly" in html and 'src="https://cdn.plot.ly' not in html and len(html) > 2_000_000  # JS embedded


# --- usage errors, help, version: through the real entry point --------------------------------

USAGE_ERRORS = [
    (["optimize", "{P}", "--bogus", "1"], "error: no such option --bogus; see `hisopt optimize --help`"),
    (["optimize", "{P}", "--pop", "abc"], "error: --pop: expected an integer, got 'abc'"),
    (["optimize"], "error: missing argument PROBLEM"),
    (["bogus"], "error: no such command 'bogus'; expected one of "),
    (["optimize", "{P}", "--popp", "3"], "error: no such option --popp; did you mean --pop?"),
    (["optimise", "{P}"], "error: no such command 'optimise' (did you mean 'optimize'?); expected one of "),
    (
        ["droptest", "{P}", "--out", "x", "--height", "five"],
        "error: --height: expected a number (SI) or a number with a unit, e.g. \"25 mm\" or 0.025 [m]; got 'five'",
    ),
    (["droptest", "{P}", "--out", "x", "--height", "5kg"], 'error: --height: "5kg" is a mass; expected a length (e.g. "25 mm" or 0.025 [m])'),
    (["droptest", "{P}"], "error: missing option --out"),
    (["optimize", "{P}", "--pop"], "error: --pop: expected a value"),
]


@pytest.mark.parametrize(("args", "expected"), USAGE_ERRORS, ids=[" ".join(a) for a, _ in USAGE_ERRORS])
def test_usage_errors_are_one_line_exit_2(args, expected, tmp_path):
    out = subprocess.run([sys.executable, "-m", "hisopt", *[a.format(P=DEFAULT_PROBLEM) for a in args]],
                         capture_output=True, text=True, timeout=120, cwd=tmp_path)  # fmt: skip
    assert out.returncode == 2, out.stderr
    assert out.stderr.startswith(expected) and out.stderr.count("\n") == 1, out.stderr
    assert out.stdout == "" and not (tmp_path / "x").exists()


def test_bare_hisopt_prints_the_help_and_exits_0():
    out = run()
    assert out.returncode == 0 and out.stderr == ""
    assert out.stdout.startswith("Usage: hisopt") and "Commands:" in out.stdout and "optimize" in out.stdout


def test_version_is_the_installed_distribution_version():
    from importlib.metadata import version

    out = run("--version")
    assert out.returncode == 0 and out.stdout == f"hisopt {version('hisopt')}\n"


def _commands() -> list[str]:
    from hisopt.cli import app

    return [c.name or c.callback.__name__ for c in app.registered_commands]


def test_every_help_reads_cleanly():
    """No rich markup eaten, no type noise on flags, summaries not cut off, and each command's
    description is whole sentences (a paragraph of the docstring is rewrapped, not cut)."""
    top = run("--help")
    assert top.returncode == 0
    listing = top.stdout.split("Commands:")[1]
    assert "..." not in listing and all(f"  {name} " in listing for name in _commands())
    for name in _commands():
        out = run(name, "--help")
        assert out.returncode == 0, out.stderr
        for noise in ("<bool>", "list[str]", "{problem}", "{run_dir}", "a  value", "Error"):
            assert noise not in out.stdout, (name, noise)
        description = re.split(r"\n(?:Arguments|Options):", out.stdout)[0].split("\n\n")[1:]
        for par in filter(str.strip, description):
            assert " ".join(par.split()).endswith((".", ")")), (name, par)
            assert all(len(line.strip()) > 40 for line in par.strip().splitlines()[:-1]), (name, par)  # filled lines


def test_set_help_names_every_key_set_accepts(problem):
    """SET_KEYS (listed so that --help need not import the model) are the scalar fields of the
    [his] model; --help names each, and --set accepts each."""
    from pydantic import BaseModel

    from hisopt.cli.options import SET_KEYS
    from hisopt.hydraulics.roll_plane import RollPlaneHIS

    def is_model(annotation) -> bool:  # tables and lists ([his.parameters], [[his.circuits]]) are not scalars
        args = getattr(annotation, "__args__", ())
        container = any(getattr(a, "__origin__", None) in (dict, list) for a in (annotation, *args))
        return container or any(isinstance(a, type) and issubclass(a, BaseModel) for a in (annotation, *args))

    scalar = [n for n, f in RollPlaneHIS.model_fields.items() if not is_model(f.annotation)]
    assert list(SET_KEYS) == scalar
    help_text = " ".join(run("modes", "--help").stdout.split())
    assert f"KEY is one of {', '.join(SET_KEYS)}" in help_text and "[his]" in help_text
    his = problem.spec.his.model_dump()
    for key in SET_KEYS:
        value = his[key] if his[key] is not None else his[key.removesuffix("_rear")]
        assert problem.with_values(**{key: value}).spec.his.model_dump()[key] == value


def test_set_keys_are_derived_from_the_his_model(tmp_path, monkeypatch):
    """SET_KEYS is read from RollPlaneHIS's source: today's keys (written out once here), each a
    field of the imported model; and the reading follows a model it has never seen (a new
    scalar field becomes a key, sub-tables of every kind do not), compared with pydantic's own
    field list of that model imported."""
    from pydantic import BaseModel

    from hisopt.cli.options import SET_KEYS
    from hisopt.cli.usage import scalar_fields
    from hisopt.hydraulics.roll_plane import RollPlaneHIS

    today = (
        "p0",
        "dA",
        "lam",
        "Rv",
        "dA_rear",
        "lam_rear",
        "Rv_rear",
        "bore",
        "rod",
        "bore_rear",
        "rod_rear",
        "V0",
        "gamma",
        "chamber_volume",
        "valve_laminar_fraction",
        "orifice_diameter",
        "orifice_diameter_rear",
        "discharge_coefficient",
        "cracking_pressure",
        "cracking_pressure_rear",
        "blowoff_resistance",
        "blowoff_resistance_rear",
        "laminar_resistance",
        "valve_flow_rms",
        "separator",
        "pressure_rating",
        "max_working_pressure",
        "pipe_model",
        "layout",
    )
    assert SET_KEYS == today
    assert set(SET_KEYS) <= set(RollPlaneHIS.model_fields)

    (tmp_path / "set_keys_probe.py").write_text(
        "from typing import Literal\n"
        "from pydantic import BaseModel\n"
        "from hisopt.hydraulics.fluid import Fluid\n"
        "from hisopt.hydraulics.network import PipeModel\n"
        "Mode = Literal['a', 'b']\n"
        "class Sub(BaseModel):\n"
        "    x: float = 1.0\n"
        "class Probe(BaseModel):\n"
        "    a: float = 1.0\n"
        "    fluid: Fluid = Fluid()\n"
        "    sub: Sub | None = None\n"
        "    b: int | None = None\n"
        "    table: dict[str, float] = {}\n"
        "    rows: list[Sub] | None = None\n"
        "    mode: Mode = 'a'\n"
        "    pipe_model: PipeModel = 'lumped'\n"
        "    new_key: str = 'x'\n",
        encoding="utf-8",
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    import set_keys_probe

    def is_table(annotation) -> bool:  # the imported model's view: a container or a model
        args = getattr(annotation, "__args__", ())
        container = any(getattr(a, "__origin__", None) in (dict, list) for a in (annotation, *args))
        return container or any(isinstance(a, type) and issubclass(a, BaseModel) for a in (annotation, *args))

    imported = tuple(n for n, f in set_keys_probe.Probe.model_fields.items() if not is_table(f.annotation))
    assert imported == ("a", "b", "mode", "pipe_model", "new_key")
    assert scalar_fields("set_keys_probe", "Probe") == imported


def test_help_and_version_import_no_numerical_stack():
    """The timing-free proxy for a fast `hisopt --help`: the CLI module and the help itself
    import none of numpy, scipy, pandas, pymoo, casadi, plotly, dask, nor pint (units are read
    only when a value carries one), also for the commands whose numeric options take units."""
    code = (
        "import sys\n"
        "from hisopt.cli import main\n"
        "for args in (['--help'], ['--version'], [], ['droptest', '--help'], ['compare-layouts', '--help'], ['evaluate', '--help']):\n"
        "    sys.argv = ['hisopt', *args]\n"
        "    try:\n"
        "        main()\n"
        "    except SystemExit as exc:\n"
        "        assert not exc.code, exc.code\n"
        "heavy = {'numpy', 'scipy', 'pandas', 'pymoo', 'casadi', 'plotly', 'dask', 'pint'}\n"
        "print(sorted(heavy & {m.split('.')[0] for m in sys.modules}), file=sys.stderr)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stderr.strip() == "[]"


def test_importing_the_cli_leaves_the_signal_handlers_alone():
    """Importing hisopt.cli (as the console script does, argv[0] "hisopt") changes neither the
    SIGINT nor the SIGTERM handler; main() installs the command line's own (compared by
    identity with what signal.getsignal returned before the import)."""
    code = (
        "import signal, sys\n"
        "sys.argv = ['/usr/local/bin/hisopt', '--version']\n"
        "before = [signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)]\n"
        "import hisopt.cli\n"
        "after = [signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)]\n"
        "assert after == before, (before, after)\n"
        "try:\n"
        "    hisopt.cli.main()\n"
        "except SystemExit as exc:\n"
        "    assert not exc.code, exc.code\n"
        "installed = [signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)]\n"
        "assert all(h is not b for h, b in zip(installed, before, strict=True)), (before, installed)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.startswith("hisopt ")


def test_evaluate_says_when_it_shows_only_part_of_the_designs(tmp_path, problem):
    x = problem.lower + (problem.upper - problem.lower) * np.linspace(0, 1, 23)[:, None]
    path = tmp_path / "designs.csv"
    pd.DataFrame(x, columns=problem.variable_names).to_csv(path, index=False)
    out = run("evaluate", str(DEFAULT_PROBLEM), "--designs", str(path))
    assert out.returncode == 0, out.stderr
    assert "showing the first 20 of 23 designs; write them all with --out FILE" in out.stdout
    assert "showing" not in run("evaluate", str(DEFAULT_PROBLEM)).stdout


# --- hisopt init -----------------------------------------------------------------------------------


def test_packaged_template_is_the_shipped_problem_file():
    """One source of truth: hisopt/data/roll_plane_his.toml (what `hisopt init` writes, and all
    a wheel user has) is byte for byte problems/roll_plane_his.toml."""
    packaged = Path(hisopt.__file__).parent / "data" / "roll_plane_his.toml"
    assert packaged.read_bytes() == DEFAULT_PROBLEM.read_bytes()


def test_init_writes_the_paper_problem_and_refuses_to_overwrite(tmp_path):
    target = tmp_path / "problem.toml"
    out = run("init", str(target))
    assert out.returncode == 0, out.stderr
    assert target.read_bytes() == DEFAULT_PROBLEM.read_bytes()
    assert "[Pa]" in target.read_text() and target.read_text().startswith("#")  # commented, with units
    target.write_text("# mine\n")
    out = run("init", str(target))
    assert out.returncode == 2 and out.stderr.count("\n") == 1
    assert str(target) in out.stderr and "--force" in out.stderr
    assert target.read_text() == "# mine\n"
    assert run("init", str(target), "--force").returncode == 0
    assert target.read_bytes() == DEFAULT_PROBLEM.read_bytes()
    ours, shipped = run("evaluate", str(target)), run("evaluate", str(DEFAULT_PROBLEM))
    assert ours.returncode == 0 and ours.stdout == shipped.stdout


# --- usage-error mapping with plain click (what typer < 0.29 raises) ---------------------------


def test_usage_error_lines_from_plain_click_exceptions():
    """typer < 0.29 raises click's own classes, typer 0.29 its copies: the same lines for both."""
    click = pytest.importorskip("click")
    from hisopt.cli.usage import integer, usage_error_line

    def click_integer(text: str) -> int:  # typer < 0.29: typer.BadParameter is click's
        try:
            return integer(text)
        except Exception as exc:
            raise click.BadParameter(str(exc.message)) from None

    @click.group()
    def group() -> None:
        pass

    @group.command("optimize")
    @click.argument("problem", metavar="PROBLEM")
    @click.option("--pop", type=click.types.FuncParamType(click_integer))
    @click.option("--out", required=True)
    def optimize(problem: str, pop: int | None, out: str) -> None:
        pass

    def line(*args: str) -> str | None:
        with pytest.raises(click.UsageError) as info:
            group.main(list(args), prog_name="hisopt", standalone_mode=False)
        return usage_error_line(info.value, args)

    assert line("optimize", "p.toml", "--out", "o", "--pop", "abc") == "--pop: expected an integer, got 'abc'"
    assert line("optimize", "p.toml", "--out", "o", "--bogus", "1") == ("no such option --bogus; see `hisopt optimize --help`")
    assert line("optimize", "p.toml", "--out", "o", "--popp", "1") == "no such option --popp; did you mean --pop?"
    assert line("optimize", "--out", "o") == "missing argument PROBLEM"
    assert line("optimize", "p.toml") == "missing option --out"
    assert line("bogus") == "no such command 'bogus'; expected one of optimize"
    assert line("optimize", "p.toml", "--out") == "--out: expected a value"
    assert usage_error_line(ValueError("not a usage error"), []) is None
