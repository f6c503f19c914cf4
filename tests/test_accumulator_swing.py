"""The accumulators' dynamic margin and rating (docs/model.md §16.9).

Independent references: the paper's layout in closed form (an accumulator alone on its
circuit holds the oil the circuit's chambers displace, ``a_c . G X``); the state space (the
realisation's map back to the node pressures, through poles and residues) against the direct
solve of the network; the evaluator's ``accumulator_swing`` against the RMS of the direct
solve's PSD on a fine grid and the static room by hand; ISO 8608's class step (one class
rougher is twice the amplitude, so twice the swing, exactly).
"""

from __future__ import annotations

import tomllib

import numpy as np
import pytest

from hisopt.coupled.response import accumulator_outputs
from hisopt.evaluation.channels import DirectOutputs, ModalChannels
from hisopt.evaluation.symmetry import split, state_mirror
from hisopt.linalg import join
from hisopt.problem import problem_from_dict
from hisopt.vehicle import stroke_matrix
from tests.cli_inprocess import run_cli
from tests.conftest import DEFAULT_PROBLEM, ROOT, random_designs
from tests.error_budget import EPS, SAFETY, assert_discriminating, network_condition, pole_budget, solve_budget, state_space_budget

ENVELOPE = ROOT / "problems" / "roll_plane_his_envelope.toml"


def single_case(path, **top) -> dict:
    """A problem file's data without its load cases (one road, one operating point)."""
    data = tomllib.loads(path.read_text())
    for key in ("scenarios", "robust"):
        data.pop(key, None)
    data["constraints"] = []
    return data | top


def charged(layout: str | None = None, **his) -> dict:
    data = single_case(ENVELOPE)
    data["his"] |= his
    if layout is not None:
        data["his"]["layout"] = layout
    return data


def test_an_accumulator_alone_on_its_circuit_holds_the_oil_its_chambers_displace(rng):
    """The paper's layout: no other storage, so ``C p = a_c . G X`` exactly (docs/model.md §3.8, step 3)."""
    problem = problem_from_dict(tomllib.loads(DEFAULT_PROBLEM.read_text()))
    x = random_designs(problem, 6, rng)
    model = problem.model(x)
    s = 2j * np.pi * np.geomspace(0.3, 80, 25)
    h_x = model.frequency_response(s)
    volume = model.accumulator_response(s, h_x)  # (n, F, 2, 4)
    net = model.his.network
    incidence = np.asarray(model.his.incidence)
    for j, (_, _, row) in enumerate(net.accumulators()):
        a_c = incidence[:, net.port_circuit == net.circuit[row]].sum(axis=1)  # (n, 4)
        displaced = np.einsum("nw,wd,nfdi->nfi", a_c, stroke_matrix(problem.vehicle), h_x)
        # one network solve and one product more than the displaced volume: a few eps of the
        # largest response (the network's condition is near 1: one node, its valves in series)
        scale = np.abs(displaced).max(axis=(1, 2), keepdims=True)
        assert np.all(np.abs(volume[:, :, j] - displaced) <= SAFETY * 16 * EPS * scale)


@pytest.mark.parametrize(
    "data",
    [
        pytest.param(charged(), id="charged"),
        pytest.param(charged("roll_plane_twin_accumulator"), id="twin-accumulators"),
        pytest.param(charged("roll_plane_accumulator_valves"), id="accumulator-valves"),
    ],
)
@pytest.mark.parametrize("halves", [True, False])
def test_state_space_volumes_equal_the_direct_solve(data, halves, rng, monkeypatch):
    """Poles and residues of the realisation's node pressures (split into mirror halves or
    not) against the network solved at each frequency, within the rounding of both paths:
    the pivot's pressure by its circuit's oil balance (charged), accumulators beside
    storage (twin), algebraic nodes behind valves (accumulator valves). Chamber compliances
    are left out: their stiff oil springs give eigenvalue bounds too loose to discriminate
    (tests/test_core.py compares their motion)."""
    import hisopt.evaluation.channels as channels

    if not halves:
        monkeypatch.setattr(channels, "split", lambda ss, mirror: None)
    problem = problem_from_dict(data, warn_implausible=False)
    x = random_designs(problem, 12, rng)  # the corners short the valves (Rv = 0): merged nodes
    seen = set()
    for _, model in problem.model(x).groups():
        seen |= assert_hydraulic_rows_equal_the_direct_solve(model, accumulator_outputs(len(model.his.network.accumulators())), halves)
    assert ("sym" in seen) == halves  # the mirror halves were used where asked (the corners may break the symmetry)


def assert_hydraulic_rows_equal_the_direct_solve(model, outputs: dict, halves: bool = True) -> set[str]:
    """Outputs read from the realisation's hydraulic unknowns (``outputs``), by poles and
    residues against the network solved at each frequency, within the rounding of both paths
    (the poles', the car's and the realisation's solves and the network's rows of ``M^-1 P``);
    returns the pole-residue forms used (``"sym"``, ``"anti"`` or ``"both"``)."""
    ss = model.state_space()
    fast = ModalChannels(model, ss, outputs)
    f_hz = np.geomspace(0.3, 80, 40)
    omega = 2 * np.pi * np.broadcast_to(f_hz, (len(ss.a), f_hz.size))
    h_fast, h_direct = fast(omega), DirectOutputs(model, outputs)(omega)
    mirror = split(ss, state_mirror(model, ss)) if halves else None
    forms = [h.a for h in mirror.values()] if mirror else [ss.a]
    network = SAFETY * EPS * network_condition(model, 2j * np.pi * f_hz).max(axis=-1)
    budget = pole_budget(forms, f_hz[0], f_hz[-1], power=1) + solve_budget(model, f_hz, power=1) + state_space_budget(model, f_hz) + network
    assert_discriminating(budget)
    exact = {name: join(*h_direct[name]) for name in ("sym", "anti")}
    scale = np.maximum(*(np.abs(b).max(axis=(1, 2), keepdims=True) for b in exact.values()))
    for name, b in exact.items():
        error = np.max(np.abs(join(*h_fast[name]) - b) / scale, axis=(1, 2, 3))
        assert np.all(error <= budget), (name, float(np.max(error / budget)))
    return set(fast.forms)


def test_the_swing_is_the_oil_volumes_rms_over_the_static_room_by_hand(rng):
    problem = problem_from_dict(charged() | {"constraints": [{"name": "accumulator_swing", "limit": 0.5}]}, warn_implausible=False)
    x = random_designs(problem, 8, rng, corners=False)
    ev = problem.evaluator()
    swing = ev(x)["accumulator_swing"]
    model = problem.model(x)
    outputs = accumulator_outputs(2)
    f = np.geomspace(ev.f_lo, ev.f_hi, 40001)
    psd = ev.spectra(np.broadcast_to(f, (len(x), f.size)), DirectOutputs(model, outputs)(2 * np.pi * f[None]))  # (n, F, 2)
    sigma = np.sqrt(np.trapezoid(psd, f, axis=1))  # (n, 2) [m^3]
    his = model.his
    rooms = []
    for k, e, _ in his.network.accumulators():
        v0 = his.params[e.volume] if isinstance(e.volume, str) else e.volume
        gas = np.broadcast_to(his.values.gas[k][0], len(x))
        rooms.append(np.minimum(gas, v0 - gas))
    by_hand = np.max(sigma / np.stack(rooms, axis=1), axis=1)
    # the evaluator's quadrature is held to 1e-4 of each integral (a square root halves it);
    # the trapezoid on 40,001 log-spaced points is within 1e-5 of these smooth integrands
    np.testing.assert_allclose(swing, by_hand, rtol=2e-4)
    assert np.all(swing > 0)


def test_one_road_class_rougher_doubles_the_swing():
    """ISO 8608: each class step is four times the displacement PSD, so twice every RMS."""
    rows = []
    for road_class in ("C", "D"):
        data = charged() | {"constraints": [{"name": "accumulator_swing", "limit": 0.5}]}
        data["road"] = data["road"] | {"class": road_class}
        problem = problem_from_dict(data, warn_implausible=False)
        rows.append(problem.evaluator()(random_designs(problem, 5, np.random.default_rng(3)))["accumulator_swing"])
    # the same nodes and the same PSDs times 4: the rounding of one product and a square root
    np.testing.assert_allclose(rows[1], 2.0 * rows[0], rtol=16 * EPS)


def test_the_rating_follows_the_separator_or_the_given_value():
    from hisopt.coupled.operating_point import accumulator_quantities

    usage = {}
    for his in ({}, {"separator": "bladder"}, {"pressure_rating": 5.0}):
        problem = problem_from_dict(charged(**his), warn_implausible=False)
        q = accumulator_quantities(problem.model(problem.baseline[None]).his)
        usage[str(his)] = (float(q["pressure_rating_usage"][0]), float(q["static_pressure_ratio"][0]))
    for key, rating in (("{}", 8.0), ("{'separator': 'bladder'}", 4.0), ("{'pressure_rating': 5.0}", 5.0)):
        used, ratio = usage[key]
        assert used == ratio / rating


@pytest.mark.parametrize(
    "his, message",
    [
        ({"pressure_rating": 1.0}, "his.pressure_rating"),
        ({"separator": "piston"}, "his.separator"),
    ],
)
def test_a_bad_rating_is_one_line_naming_the_key(tmp_path, his, message):
    lines = DEFAULT_PROBLEM.read_text().splitlines()
    at = next(i for i, line in enumerate(lines) if line.startswith("[his]")) + 1
    lines[at:at] = [f"{key} = {value!r}".replace("'", '"') for key, value in his.items()]
    text = "\n".join(lines) + "\n"
    path = tmp_path / "bad.toml"
    path.write_text(text)
    result = run_cli("evaluate", str(path))
    code, err = result.code, result.stderr
    assert code == 2 and message in err and len(err.strip().splitlines()) == 1, err


def test_the_swing_of_the_idealisation_is_refused_with_its_reason(tmp_path):
    path = tmp_path / "ideal.toml"
    path.write_text(DEFAULT_PROBLEM.read_text() + '\n[[constraints]]\nname = "accumulator_swing"\nlimit = 0.3\n')
    result = run_cli("evaluate", str(path))
    code, err = result.code, result.stderr
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert "constraints." in err and "[his.charge]" in err and "holds none" in err


def test_the_casadi_refinement_says_it_has_no_swing():
    pytest.importorskip("casadi")
    from hisopt.errors import RunError
    from hisopt.optim.gradient.casadi_model import CasadiModel

    problem = problem_from_dict(charged() | {"constraints": [{"name": "accumulator_swing", "limit": 0.5}]}, warn_implausible=False)
    with pytest.raises(RunError, match="--method slp"):
        CasadiModel(problem)
