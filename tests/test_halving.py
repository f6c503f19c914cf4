"""Successive halving (docs/model.md §20.4, :mod:`hisopt.studies.halving`), on synthetic candidates.

- the rung arithmetic equals the closed form, computed here with exact fractions: rung r
  takes ceil(n / 3^(r-1)) candidates at G 3^(r-1) generations with one seed, the last rung
  at least the best ten (all of the rung before if fewer) at the full budget with every
  seed; the K = 10 full-car robust search's plan by hand;
- applied to candidates with known scores measured with noise that shrinks with the budget
  (the standard deviation ~ 1 / generations), the true best is the winner for every noise
  draw; with noise that does not shrink it is not (so the test can fail);
- the rung sizes successive_halving runs are the plan's, every candidate is ranked once;
- plans that leave no candidate for the last rung, a first budget below one generation and
  a rung before the last at the full budget are refused naming the option;
- the Spearman helper's ranks are scipy's average ranks.
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
from scipy.stats import rankdata

from hisopt.errors import ConfigError
from hisopt.studies.halving import (
    default_first_generations,
    default_rungs,
    halving_plan,
    max_rungs,
    successive_halving,
)
from hisopt.studies.synthesis_halving import average_ranks, spearman


@pytest.mark.parametrize("n", [1, 2, 3, 4, 9, 10, 28, 82, 100, 2039])
def test_rung_sizes_and_budgets_equal_the_closed_form(n):
    for rungs in range(1, max_rungs(n) + 1):
        first, full = 2, 2 * 3 ** max(rungs - 2, 0) + 1
        plan = halving_plan(n, rungs, first, full, [4, 5, 6])
        assert [g.number for g in plan] == list(range(1, rungs + 1))
        thirds = [math.ceil(Fraction(n, 3 ** (r - 1))) for r in range(1, rungs + 1)]
        if rungs > 1:  # the last rung keeps the best ten, or all of the rung before if fewer
            thirds[-1] = max(thirds[-1], min(10, thirds[-2]))
        assert [g.candidates for g in plan] == thirds
        assert [g.generations for g in plan] == [first * 3 ** (r - 1) for r in range(1, rungs)] + [full]
        assert [g.seeds for g in plan] == [(4,)] * (rungs - 1) + [(4, 5, 6)]
        assert plan[-1].candidates >= 1 and (rungs == 1 or plan[-2].candidates >= 2)
    with pytest.raises(ConfigError) as err:
        halving_plan(n, max_rungs(n) + 1, 1, 10**9, [1])
    assert err.value.key == "--rungs"


def test_the_full_car_k10_plan_by_hand():
    # 2,039 screened in (docs/model.md §20.4): default 6 rungs, 1 generation first, 200 full
    assert default_rungs(2039, 200) == 6 and default_first_generations(6, 200) == 1
    plan = halving_plan(2039, 6, 1, 200, [1, 2, 3])
    assert [(g.candidates, g.generations, len(g.seeds)) for g in plan] == [(2039, 1, 1), (680, 3, 1), (227, 9, 1), (76, 27, 1), (26, 81, 1), (10, 200, 3)]
    # one rung (every candidate at the full budget) up to 10 candidates; then until the rung
    # before the last holds at most 30 (its best ten go on): 11 -> 10, 30 -> 10, 31 -> 11 -> 10
    assert [default_rungs(n) for n in (1, 10, 11, 30, 31, 90, 91)] == [1, 1, 2, 2, 3, 3, 4]
    assert [g.candidates for g in halving_plan(31, 3, 1, 100, [1])] == [31, 11, 10]
    # fewer rungs where one before the last would reach the full budget of 10: with G = 1,
    # rung 4 of 5 would run 27; with G = 2, rung 3 of 4 would run 18
    assert default_rungs(2039, 10) == 4 and default_rungs(2039, 10, first_generations=2) == 3
    assert halving_plan(2039, 4, 1, 10, [1])[-2].generations == 9


def _noisy_scores(true: np.ndarray, shrinking: bool, rng: np.random.Generator, calls: list):
    def score(names, rung):
        calls.append((len(names), rung.generations, rung.seeds))
        sd = 10.0 / rung.generations if shrinking else 10.0
        return [float(true[i] + sd * rng.standard_normal()) for i in names]

    return score


def test_the_true_best_is_kept_when_the_noise_shrinks_with_the_budget():
    # 100 candidates with scores 0..99 (the best: 99, a gap of 1 to the next), measured with
    # a standard deviation of 10 / generations: 10 at the first rung (where the best third
    # only has to keep the best among the top 34 of 100), 0.04 at the last (G 81 -> F 243)
    n, rungs = 100, 5
    plan = halving_plan(n, rungs, 1, 243, [1, 2, 3])
    true = np.random.default_rng(0).permutation(n).astype(float)  # the screen's order knows nothing
    winners, lost = [], 0
    for draw in range(20):
        calls: list = []
        found = successive_halving(list(range(n)), plan, _noisy_scores(true, True, np.random.default_rng(draw), calls))
        winners.append(true[found.ranking[0]])
        assert calls == [(g.candidates, g.generations, g.seeds) for g in plan]  # once per rung, its size and budget
        assert [len(e) for e in found.entrants] == [g.candidates for g in plan]
        assert sorted(found.ranking) == list(range(n))  # everyone ranked once
        assert found.reached(found.ranking[0]) == rungs and found.reached(found.ranking[-1]) in range(1, rungs)
        flat = successive_halving(list(range(n)), plan, _noisy_scores(true, False, np.random.default_rng(draw), []))
        lost += true[flat.ranking[0]] != n - 1
    assert winners == [n - 1] * 20
    assert lost >= 5  # the same plan with noise that stays at 10: the best often lost


def test_ties_keep_the_given_order_and_each_rung_keeps_the_best_third():
    plan = halving_plan(40, 2, 1, 2, [1])
    names = [f"c{i:02d}" for i in range(40)]
    good = names[::3]  # 14 = ceil(40 / 3), above the floor of ten
    found = successive_halving(names, plan, lambda current, rung: [1.0 if c in good else 0.0 for c in current])
    assert found.entrants == [names, good]
    found = successive_halving(names, plan, lambda current, rung: [0.0] * len(current))
    assert found.entrants[1] == names[:14] and found.ranking == names
    # the floor: 7 candidates keep all seven (fewer than ten), 13 keep ten, not ceil(13 / 3) = 5
    assert [g.candidates for g in halving_plan(7, 2, 1, 2, [1])] == [7, 7]
    found = successive_halving(names[:13], halving_plan(13, 2, 1, 2, [1]), lambda current, rung: [-int(c[1:]) for c in current])
    assert found.entrants[1] == names[:10]
    # another finalist count: 13 -> 5 with one, 13 -> 13 with twenty
    assert [g.candidates for g in halving_plan(13, 2, 1, 2, [1], finalists=1)] == [13, 5]
    assert [g.candidates for g in halving_plan(13, 2, 1, 2, [1], finalists=20)] == [13, 13]
    assert default_rungs(2039, 200, finalists=30) == 5 and default_rungs(2039, 10**6, finalists=1) == 8  # 2,039 / 3^7 <= 1
    with pytest.raises(ValueError, match="a plan for 40"):
        successive_halving(list("abc"), plan, lambda current, rung: [0.0] * len(current))


@pytest.mark.parametrize(
    ("args", "key", "needle"),
    [
        ((4, 4, 1, 100), "--rungs", "leaving none for rung 4"),  # 4 -> 2 -> 1: rung 3 alone
        ((3, 3, 1, 10), "--rungs", "at most 2 rungs"),
        ((1, 2, 1, 10), "--rungs", "at most 1 rung"),
        ((100, 3, 0, 10), "--first-gens", "at least 1 generation"),
        ((100, 3, 4, 12), "--first-gens", "rung 2 would run 12 generations"),
        ((100, 0, 1, 10), "--rungs", "at least 1 rung"),
    ],
)
def test_bad_plans_are_refused_naming_the_option(args, key, needle):
    n, rungs, first, full = args
    with pytest.raises(ConfigError) as err:
        halving_plan(n, rungs, first, full, [1])
    assert err.value.key == key and needle in str(err.value), str(err.value)


def test_average_ranks_are_scipys_and_spearman_says_agreement():
    values = [3.0, 1.0, 3.0, 7.0, -2.0, 1.0]
    np.testing.assert_array_equal(average_ranks(values), rankdata([-v for v in values]))
    # tuples (with a gain, value) rank every gain above every hypervolume
    assert list(average_ranks([(0, 5.0), (1, -3.0), (1, 2.0)])) == [3.0, 2.0, 1.0]
    assert spearman([1, 2, 3, 4], [9.0, 5.0, 4.0, 1.0])["rho"] == pytest.approx(1.0)
    assert spearman([1, 2, 3, 4], [1.0, 4.0, 5.0, 9.0])["rho"] == pytest.approx(-1.0)
    assert spearman([1, 2], [1.0, 2.0])["rho"] is None
