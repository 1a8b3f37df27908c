"""The arrival-time distribution of ``task=target`` (swimrl.evaluation.statistics): the
Kaplan-Meier CDF (censoring at ``T`` only), the restricted mean time and the times by which a
quarter and half of all swimmers arrived, from hand-made flow chunks."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from swimrl.evaluation.statistics import chunk_outcomes, outcome_statistics

# update_interval 0.5, 10 decisions: T = 5 tau_K, the grid every decision (10 // 200 -> 1)
DT, N = 0.5, 10
# flow 0: 4 swimmers arrive at decisions 2, 3, 3, 8; flow 1: nobody of 4; flow 2: 1 and 10 of 4
CHUNKS = [{"arrived": [1.0, 0.0], "arrival_steps": [[2, 3, 3, 8], []], "swimmers_per_flow": 4},
          {"arrived": [0.5], "arrival_steps": [[1, 10]], "swimmers_per_flow": 4}]


def test_cdf_rmst_and_half_time_by_hand():
    out = outcome_statistics(CHUNKS, DT, N)
    assert out["arrival_cdf_t"] == pytest.approx([0.5 * k for k in range(1, 11)])
    f0 = np.array([0, .25, .75, .75, .75, .75, .75, 1, 1, 1])
    f1 = np.zeros(10)
    f2 = np.array([.25] * 9 + [.5])
    flows = np.stack([f0, f1, f2])
    assert out["arrival_cdf_mean"] == pytest.approx(flows.mean(0))
    assert out["arrival_cdf_mean"][:3] == pytest.approx([1 / 12, 1 / 6, 1 / 3])
    assert out["arrival_cdf_sem"] == pytest.approx(flows.std(0, ddof=1) / math.sqrt(3))
    assert out["arrival_cdf_mean"][-1] == pytest.approx(out["arrival_mean"]) == 0.5
    # E[min(t, T)] per flow: (2+3+3+8) 0.5 / 4 = 2; nobody: T = 5; (0.5 + 5 + 2 x 5) / 4
    rmst = np.array([2.0, 5.0, 3.875])
    assert out["arrival_time_rmst_mean"] == pytest.approx(rmst.mean())
    assert out["arrival_time_rmst_sem"] == pytest.approx(rmst.std(ddof=1) / math.sqrt(3))
    # 12 swimmers, arrivals 1, 2, 3, 3, 8, 10: the 3rd at decision 3, the 6th at 10 (= T)
    assert out["arrival_time_quartile"] == 1.5
    assert out["arrival_time_half"] == 5.0
    # the old keys: the arrived only
    assert out["n_arrived"] == 6
    assert out["arrival_time_median"] == pytest.approx(3 * DT)


def test_half_time_never_reached_within_t():
    chunks = [{"arrived": [0.0, 0.25], "arrival_steps": [[], [5]], "swimmers_per_flow": 4}]
    out = outcome_statistics(chunks, DT, N)
    assert out["arrival_time_half"] is None and out["arrival_time_quartile"] is None
    assert out["arrival_cdf_mean"][-1] == pytest.approx(0.125)
    assert out["arrival_time_rmst_mean"] == pytest.approx((5.0 + (2.5 + 3 * 5.0) / 4) / 2)
    nobody = [{"arrived": [0.0], "arrival_steps": [[]], "swimmers_per_flow": 3}]
    out = outcome_statistics(nobody, DT, N)
    assert out["arrival_time_half"] is None and out["arrival_time_median"] is None
    assert out["arrival_cdf_mean"] == [0.0] * 10 and out["arrival_time_rmst_mean"] == 5.0


@pytest.mark.parametrize("n, every, last", [(450, 2, 450), (401, 2, 401), (2000, 10, 2000)])
def test_grid_every_n_over_200_decisions_up_to_t(n, every, last):
    chunks = [{"arrived": [0.5], "arrival_steps": [[1, n]], "swimmers_per_flow": 4}]
    t = np.asarray(outcome_statistics(chunks, 0.1, n)["arrival_cdf_t"]) / 0.1
    assert t[0] == pytest.approx(every) and t[-1] == pytest.approx(last)
    assert np.all(np.diff(t) > 0) and np.all(np.diff(t)[:-1] == pytest.approx(every))


def test_records_without_the_swimmer_count_keep_the_old_keys():
    """A partial record written before ``swimmers_per_flow`` (or no decision count): no
    distribution keys, the rest as before."""
    old = [{k: v for k, v in c.items() if k != "swimmers_per_flow"} for c in CHUNKS]
    for out in (outcome_statistics(old, DT, N), outcome_statistics(CHUNKS, DT),
                outcome_statistics([CHUNKS[0], old[1]], DT, N)):
        assert out["n_arrived"] == 6 and "arrival_mean" in out
        assert not any(k.startswith(("arrival_cdf", "arrival_time_rmst")) for k in out)
        assert "arrival_time_half" not in out


def test_chunk_outcomes_records_the_swimmers_per_flow():
    time = torch.tensor([[0.5, math.nan, 1.5, math.nan], [math.nan, math.nan, math.nan, 2.0]])
    outcomes = {"energy": torch.ones(2, 4), "arrived": time.isfinite().double(),
                "arrival_time": time, "final_distance": torch.zeros(2, 4)}
    out = chunk_outcomes(outcomes, slice(1, 4), DT)
    assert out["swimmers_per_flow"] == 3
    assert out["arrival_steps"] == [[3], [4]]
    assert "swimmers_per_flow" not in chunk_outcomes({"energy": torch.ones(2, 4)}, slice(0, 2), DT)
