r"""``swimrl-fit-minimal``: fit the paper's minimal model (``eq:fit``) to a strategy.

The run directory gets ``fit.json`` with ``c1..c4``, their standard errors, ``R^2`` and the
command that evaluates the fitted model:

    swimrl-fit-minimal strategy=policy policy=pretrained/ku10 flow.kubo=10
"""

from __future__ import annotations

from pathlib import Path

from omegaconf import DictConfig

from swimrl.analysis.fit_minimal import FitConfig, run_fit
from swimrl.cli import command, run_dir
from swimrl.config import fit_config
from swimrl.runs.layout import RunLayout
from swimrl.runs.records import refuse_overwrite, write_json


def check(cfg: DictConfig, out: Path | None) -> FitConfig:
    """Parse and check the config; refuse to replace a result."""
    c = fit_config(cfg)
    if out is not None:
        refuse_overwrite(RunLayout(out).fit, c.eval.overwrite)
    return c


@command("fit_minimal", check=check)
def main(cfg: DictConfig) -> dict:
    c = check(cfg, run_dir())
    out = RunLayout(run_dir()).fit
    record = run_fit(c)
    write_json(record, out)
    co, e = record["coefficients"], record["stderr"]
    print(
        "minimal model fit: "
        + ", ".join(f"{k} = {co[k]:.4f} +- {e[k]:.4f}" for k in co)
        + f"; R^2 = {record['r2']:.3f} over {record['n_samples']} samples\n"
        + record["evaluate_with"]
    )
    return record


if __name__ == "__main__":
    main()
