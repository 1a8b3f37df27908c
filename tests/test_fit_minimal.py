"""The minimal-model fit recovers known coefficients from data it did not generate itself."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
import torch

from swimrl.analysis.fit_minimal import fit_minimal
from swimrl.policies.baselines import minimal_model

from .conftest import SMALL


def test_fit_recovers_coefficients_from_noisy_samples():
    rng = np.random.default_rng(0)
    n = 4000
    sig = np.column_stack(
        [
            rng.uniform(-1, 1, n),
            rng.uniform(-1, 1, n),
            rng.normal(0, 0.5, n),
            rng.normal(0, 0.5, n),
            rng.normal(0, 1, n),
        ]
    )
    true = (1.3, -0.7, 0.4, 0.9)
    lam = minimal_model(torch.from_numpy(sig), true, 0.98).numpy() + rng.normal(0, 0.02, n)
    coeffs, err, r2 = fit_minimal(sig, lam, 0.98)
    assert np.allclose(coeffs, true, atol=5 * err.max() + 1e-3)
    assert r2 > 0.99


def test_cli_fits_a_strategy(tmp_path):
    """Fitting eq:fit to the minimal model itself, sampled in the flow, returns its c_i."""
    cmd = [
        sys.executable,
        "-m",
        "swimrl.cli.fit_minimal",
        *SMALL,
        "strategy=minimal",
        "strategy.c1=1.5",
        "strategy.c2=0.5",
        "strategy.c3=-0.5",
        "strategy.c4=0.8",
        "eval.n_flows=2",
        "eval.n_swimmers=50",
        "fit.sample_every=1",
        f"hydra.run.dir={tmp_path}",
    ]
    out = subprocess.run(cmd, capture_output=True, text=True, check=True)
    assert "minimal model fit" in out.stdout
    rec = json.loads((tmp_path / "fit.json").read_text())
    c = rec["coefficients"]
    assert [c["c1"], c["c2"], c["c3"], c["c4"]] == pytest.approx([1.5, 0.5, -0.5, 0.8], abs=1e-3)
    assert rec["evaluate_with"].startswith("swimrl-eval strategy=minimal strategy.c1=1.5")
    # each flow alone recovers them too (noise-free samples), so their spread is ~0
    for k, want in zip(("c1", "c2", "c3", "c4"), (1.5, 0.5, -0.5, 0.8), strict=True):
        assert rec["per_flow"][k] == pytest.approx([want, want], abs=1e-3)
        assert 0 <= rec["flow_sem"][k] < 1e-3
