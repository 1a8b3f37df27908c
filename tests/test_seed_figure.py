"""Fig. seedSpread (:mod:`swimrl.paper.seeds`): the three seeds' records read as they are,
the DNS transfer pooled over realisations and paired with STO, pending without records."""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from swimrl.paper import seeds

ROOT = Path(__file__).resolve().parents[1] / "docs" / "results" / "three_seeds"


def _dns_record(path: Path, sto: list[float], policies: dict[str, list[float]]) -> None:
    path.mkdir(parents=True)
    rows = [{"label": "sto", "per_flow": sto}, {"label": "naive(+0.98)", "per_flow": sto}]
    rows += [{"label": f"policy({k})", "per_flow": v} for k, v in policies.items()]
    (path / "comparison.json").write_text(json.dumps({"rows": rows}))


def test_pending_without_records(tmp_path):
    assert "pending" in seeds.build_seed_spread(tmp_path, tmp_path / "s.png")
    assert not (tmp_path / "s.png").exists()


def test_dns_transfer_pools_realisations_and_pairs_with_sto(tmp_path):
    rng = np.random.default_rng(0)
    sto = [rng.uniform(0.5, 0.6, 4) for _ in range(2)]
    smart = [s * 1.2 + rng.normal(0, 0.01, 4) for s in sto]
    for i in range(2):
        _dns_record(tmp_path / "dns_transfer" / f"seed{i + 2}", sto[i].tolist(),
                    {"docs/results/paper_runs/ku10_seed1": smart[i].tolist(),
                     "docs/results/dns_train/seed1/policy.pt": sto[i].tolist()})
    out = seeds.dns_transfer_ratios(tmp_path)
    a, b = np.concatenate(smart), np.concatenate(sto)
    r = a.mean() / b.mean()
    sem = np.std(a - r * b, ddof=1) / np.sqrt(a.size) / b.mean()
    assert out["n_flows"] == 8 and out["realisations"] == ["seed2", "seed3"]
    assert set(out) == {"realisations", "n_flows", "ku10"}     # the DNS-trained row is not a seed
    assert out["ku10"][1] == pytest.approx((r, sem), rel=1e-12)
    # a policy evaluated on some realisations only is refused, not pooled over fewer flows
    _dns_record(tmp_path / "dns_transfer" / "seed4", sto[0].tolist(), {})
    with pytest.raises(ValueError, match="missing from some"):
        seeds.dns_transfer_ratios(tmp_path)


def test_committed_records_are_read_as_the_readme_tables_quote_them():
    """The numbers the three-seed README quotes (seed 0 at the training point 1.292, seed 1 at
    T_u = 2 tau_K 1.081; c1 of seed 2 at Ku = 10 2.984; ablation (b) smart / STO of seed 0 at
    Ku = 10 1.292) are what the figure draws."""
    sweeps = seeds.sweep_ratios(ROOT)
    assert set(sweeps) == {"rot_diffusion", "duration", "update_interval", "swim_speed"}
    d = sweeps["duration"][0]
    assert round(d["ratio"][d["x"].index(200.0)], 3) == 1.292
    u = sweeps["update_interval"][1]
    assert round(u["ratio"][u["x"].index(2.0)], 3) == 1.081
    fits = seeds.fit_coefficients(ROOT)
    assert fits[2]["ku"] == [0.1, 1.0, 10.0, 1e7]
    assert round(fits[2]["c1"]["value"][2], 3) == 2.984
    abl = seeds.ablation_ratios(ROOT)
    assert round(abl["ku10"][0]["smart/STO"][0], 3) == 1.292
    assert sum(len(v) for v in abl.values()) == 12


def test_swimrl_figures_draws_it(tmp_path):
    cfg = SimpleNamespace(three_seeds=ROOT, out=tmp_path)
    out = seeds.build_seed_spread_figure(cfg)
    assert "pending" not in out and (tmp_path / "seedSpread.png").stat().st_size > 0
