r"""``swimrl-probe``: the mechanism probe of strategies and policies near alignment.

    swimrl-probe 'probe.policies=[pretrained/ku10,pretrained/ku1]'
    swimrl-probe 'probe.policies=[docs/results/three_d/runs/ku10_seed0]' kernel=compiled \
        eval.n_flows=2 eval.n_swimmers=64
    swimrl-probe 'probe.strategies=[sto,naive]' flow=stochastic3d kernel=compiled

For each strategy (``probe.strategies``, ``probe.policies`` as ``compare.strategies``,
``compare.policies``), on isotropic Gaussian states and on the states along its own
trajectories with ``n_r > probe.n_r_min``: corr(Λ, STO), corr(Λ, Λ*) and the mean tumbling
rate at Λ = 0, its own Λ, STO's and Λ* (:mod:`swimrl.analysis.mechanism_probe`). A policy is
probed in the dimension of its recorded flow and signals, and with ``probe.flow=own`` (the
default) in the flow, swimmer, episode and task of its training config; the baselines in the
command's. Prints the table and writes ``probe.json`` (the record), ``probe.md`` and
``probe.png`` to the run directory.
"""

from __future__ import annotations

import logging
from pathlib import Path

from omegaconf import DictConfig, OmegaConf

from swimrl.analysis.mechanism_probe import (
    FIGURE,
    RECORD,
    TABLE,
    ProbeConfig,
    ProbeSettings,
    Subject,
    policy_dimension,
    run_probe,
)
from swimrl.analysis.probe_report import markdown, plot_probe
from swimrl.cli import command, run_dir
from swimrl.config import env_params, eval_setup, from_node, record_of
from swimrl.errors import BadFileError, ConfigError, as_float
from swimrl.evaluation.compare import strategy_variants
from swimrl.evaluation.rollout import check_eval_memory
from swimrl.flows.labels import ku_name
from swimrl.flows.registry import flow_dimension
from swimrl.policies.baselines import StrategySpec
from swimrl.runs.atomic import atomic_write_text
from swimrl.runs.checkpoint import upgrade_config
from swimrl.runs.policy_files import load_file, resolve_policy_file, sha256_file
from swimrl.runs.records import refuse_overwrite, write_json

log = logging.getLogger(__name__)

#: The config groups a policy brings from its training config with ``probe.flow=own``.
OWN = ("flow", "swimmer", "episode", "task", "reward")


def _numbers(key: str, values) -> list[float]:
    return [as_float(key, v, lambda _: True, "a list of numbers") for v in values]


def _shown(path: Path) -> str:
    """``path`` relative to the working directory where it lies below it (records name the
    repository's files, not the machine's), else as it is."""
    try:
        return str(Path(path).resolve().relative_to(Path.cwd().resolve()))
    except ValueError:
        return str(path)


def _policy_subject(label: str, spec: str, base: dict, settings: ProbeSettings) -> Subject:
    """A trained policy: its file, recorded signals and (``probe.flow=own``) training
    config's flow, swimmer, episode and task over the command's config ``base``."""
    path = resolve_policy_file(spec)
    data = load_file(path, map_location="cpu")
    trained = upgrade_config(data.get("config") or {})
    node = {**base}
    if settings.flow == "own" and "flow" not in trained:
        raise ConfigError(f"policy={spec!r} ({path}) records no training config to take its "
                          "own flow from: allowed probe.flow=config (the command's flow=...)")
    if settings.flow == "own":
        node.update({k: trained[k] for k in OWN if k in trained})
    node["signals"] = {"names": [str(s) for s in data["signals"]]}
    trained_dim = flow_dimension(trained["flow"]) if "flow" in trained else None
    dim = policy_dimension(spec, node["signals"]["names"], str(node["flow"]["name"]),
                           flow_dimension(node["flow"]), trained_dim)
    cfg = OmegaConf.create(node)
    setup = None
    if "flows" in settings.states:
        try:
            setup = eval_setup(cfg)
        except (ConfigError, BadFileError, FileNotFoundError) as err:
            if settings.flow != "own":
                raise
            raise type(err)(f"policy={spec!r} is probed in its own training flow "
                            f"(probe.flow=own), which cannot be built here: {err} (or choose "
                            "probe.flow=config or probe.states=[gaussian])") from None
    meta = {"policy_file": _shown(path), "policy_sha256": sha256_file(path),
            "trained_flow": ku_name(trained["flow"]) if "flow" in trained else None}
    return Subject(label, StrategySpec("policy"), env_params(cfg), dim, policy=spec,
                   setup=setup, meta=meta)


def probe_config(cfg: DictConfig) -> ProbeConfig:
    """``swimrl-probe`` (``conf/probe.yaml``): the settings first, then every strategy and
    policy (each policy file read and checked: its signals' and flow's dimension)."""
    c = cfg.probe
    settings = from_node(ProbeSettings, {"probe.": c},
                         states=tuple(str(s) for s in (c.states or ())))
    try:
        variants = strategy_variants(
            [str(s) for s in (c.strategies or ())],
            _numbers("probe.naive_shape_factors", c.naive_shape_factors),
            _numbers("probe.minimal", [c.minimal[k] for k in ("c1", "c2", "c3", "c4")]),
            [str(p) for p in (c.policies or ())], [], [])
    except ConfigError as err:  # its keys are compare.*'s, these probe.*'s
        raise ConfigError(str(err).replace("compare.", "probe.")) from None
    base = record_of(cfg)
    flows = "flows" in settings.states
    subjects = []
    for v in variants:
        if v.policy is not None:
            subjects.append(_policy_subject(v.label, v.policy, base, settings))
            continue
        dim = flow_dimension(OmegaConf.to_container(cfg.flow, resolve=True))
        subjects.append(Subject(v.label, v.strategy, env_params(cfg), dim,
                                setup=eval_setup(cfg) if flows else None))
    return from_node(ProbeConfig, {"": cfg}, subjects=tuple(subjects), settings=settings,
                     record=base)


def check(cfg: DictConfig, out: Path | None) -> ProbeConfig:
    """Parse and check the config (every policy file read); refuse to replace the probe's
    record, table or figure unless ``overwrite``; refuse an evaluation the memory cannot
    hold."""
    c = probe_config(cfg)
    if out is not None:
        for name in (RECORD, TABLE, FIGURE):
            refuse_overwrite(Path(out) / name, c.overwrite)
    for s in c.subjects:
        if s.setup is not None:
            check_eval_memory(s.setup, len(c.subjects))
    return c


@command("probe", check=check)
def main(cfg: DictConfig) -> dict:
    out = run_dir()
    c = check(cfg, out)
    record = run_probe(c, log.info)
    table = markdown(record)
    print(table, flush=True)
    atomic_write_text(out / TABLE, table)
    plot_probe(record, out / FIGURE)
    target = write_json(record, out / RECORD, overwrite=c.overwrite)  # last: marks it finished
    log.info("wrote %s", target)
    return record


if __name__ == "__main__":
    main()
