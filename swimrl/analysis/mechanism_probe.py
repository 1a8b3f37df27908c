r"""Mechanism probe (``swimrl-probe``): how much of a strategy's shape choice near alignment is
STO's, and how much is the shape that stops the flow from tumbling the swimmer.

For every swimmer state with $n_r > $ ``probe.n_r_min`` (0.8: pointing away from the start,
or at the target) the probe compares the strategy's shape factor $\Lambda$ (a policy's
deterministic action, $\Lambda_\mathrm{max}\tanh\mu(s)$ as evaluation uses it) with STO's
and with the tumbling-minimising $\Lambda^*$, and measures the tumbling rate
$|\dot{\boldsymbol n}|$ each of them gives:

* ``corr_sto`` $=\mathrm{corr}(\Lambda, \Lambda_\mathrm{STO})$, ``corr_star``
  $=\mathrm{corr}(\Lambda, \Lambda^*)$ (Pearson, over the states), and
  ``corr_sto_star`` $=\mathrm{corr}(\Lambda_\mathrm{STO}, \Lambda^*)$ for reference;
* ``tumbling``: the mean of $|\dot{\boldsymbol n}|\tau_K$ at $\Lambda = 0$ (``zero``), at
  the strategy's $\Lambda$ (``subject``), at STO's (``sto``) and at $\Lambda^*$ (``star``).

**The tumbling-minimising shape** $\Lambda^* = \mathrm{clip}(\tau/(2\ell^2))$,
$\tau = \boldsymbol n\cdot(\boldsymbol\omega\times\mathbb S\boldsymbol n)$,
$\ell = |(\mathbb I - \boldsymbol n\boldsymbol n)\mathbb S\boldsymbol n|$ (in 2D
$\mathrm{clip}(-\omega/(2S_{np}))$), and the tumbling rate are those of
:mod:`swimrl.physics.tumbling`, where they are derived from (1b) and (2).

**The states.** ``gaussian``: ``probe.n_samples`` isotropic samples: $\boldsymbol n$ uniform
on the circle (2D) or the sphere (3D), $\boldsymbol e_r$ fixed ($\hat{\boldsymbol x}$,
$\hat{\boldsymbol z}$); in 2D $S_{xx}$, $S_{xy}$ of variance 1/8 (so $S_{nn}$, $S_{np}$
too) and $\omega$ of variance 1; in 3D a traceless symmetric strain
$\mathbb S = (\mathbb G + \mathbb G^{\mathsf T})/2 - \tfrac13\mathrm{tr}\,\mathbb G$,
$\mathbb G$ of independent standard normal entries, times $1/\sqrt{10}$
($\langle S_{ij}S_{ij}\rangle = 1/2$; isotropic: $\langle S_{nn}^2\rangle = 1/15$,
$\langle S_{np_1}^2\rangle = 1/20$) and vorticity components of variance 1/3; $\tau_K = 1$.
They are turned into signals by :func:`~swimrl.physics.body2d.compute_signals` and
:func:`~swimrl.physics.body3d.compute_signals_3d`
(:func:`~swimrl.analysis.gaussian_states.gaussian_states`), the same samples for every
strategy of a dimension. ``flows``: the signals and actions along the
strategy's own trajectories (:class:`~swimrl.evaluation.trajectories.TrajectoryRecorder`,
every swimmer of an evaluation at ``eval.n_flows`` x ``eval.n_swimmers``, seed ``seed``),
every decision but the first (at the start $\boldsymbol e_r := \boldsymbol n$ is a
convention) and, with ``task=target``, none after the swimmer's arrival. A policy runs in the
flow, swimmer, episode and task of its own training config (``probe.flow=own``) or in the
command's (``probe.flow=config``); strategies that share all of these share the flows
(:func:`~swimrl.evaluation.rollout.evaluate_shared`).

**Uncertainties.** Gaussian states are independent: SEM of a mean ``std/sqrt(n)``, of a
correlation ``(1 - r^2)/sqrt(n - 3)``. Along trajectories the states are correlated: every
quantity is also computed per flow (``per_flow``) and its SEM is the spread of those over
flows (``std/sqrt(F)``), the figure to quote; with 2 flows it is a rough one.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
import torch
from tensordict import TensorDict

from swimrl.analysis.gaussian_states import gaussian_states
from swimrl.env import EnvParams
from swimrl.errors import ConfigError, as_float, as_int, keep_number_types, one_of, require
from swimrl.evaluation.rollout import evaluate_shared
from swimrl.evaluation.trajectories import TrajectoryRecorder
from swimrl.flows.labels import ku_name
from swimrl.physics.body import BODIES, SHAPE_SIGNAL, body_of_signals, observable
from swimrl.physics.tumbling import stabilising_shape, tumbling_rate
from swimrl.policies.baselines import ShortTimeOptimal, StrategySpec, build_strategy
from swimrl.policies.networks import action_spec
from swimrl.runs.policy_files import load_policy
from swimrl.runs.spec import RunSpec
from swimrl.task import RewardSpec

#: ``probe.states``: isotropic Gaussian samples, the states along the strategy's trajectories.
PROBE_STATES = ("gaussian", "flows")
#: ``probe.flow``: a policy's own training flow, swimmer, episode and task, or the command's.
PROBE_FLOWS = ("own", "config")
#: The four shapes whose tumbling rate is measured, in the record's ``tumbling``.
RATES = ("zero", "subject", "sto", "star")
#: File names of the probe's outputs in the run directory.
RECORD, TABLE, FIGURE = "probe.json", "probe.md", "probe.png"



# --- STO, beside the tumbling quantities of :mod:`swimrl.physics.tumbling` ----------------


def sto_shape(signals: torch.Tensor, shape_factor_max: float) -> torch.Tensor:
    """STO's shape factor on ``signals`` ``(..., 5 | 7)``: the baselines'
    :class:`~swimrl.policies.baselines.ShortTimeOptimal` (the body read from the signals'
    width), ``(...)``."""
    return ShortTimeOptimal(shape_factor_max)(signals)[..., 0]


# --- the configuration ---------------------------------------------------------------------


def signals_dimension(names: Sequence[str]) -> int | None:
    """2 or 3 where ``names`` hold a signal of one dimension only (``n_theta`` or
    ``S_np1``, ...), None where they could be either (``n_r``, ``S_nn``)."""
    own = {b.dim: set(b.signal_names).difference(*(o.signal_names for o in BODIES.values()
                                                    if o is not b))
           for b in BODIES.values()}
    has = [d for d, only in own.items() if only & set(names)]
    if len(has) > 1:
        mix = " and ".join(f"{d}D {sorted(own[d] & set(names))}" for d in has)
        raise ConfigError(f"signals {list(names)} mix {mix} signals")
    return has[0] if has else None


def policy_dimension(spec: str, signals: Sequence[str], flow_name: str, flow_dim: int,
                     trained_dim: int | None = None) -> int:
    """The dimension a policy is probed in: that of the flow ``flow_name`` (``flow_dim``),
    checked against the policy's recorded signals and, where given, the dimension of the
    flow it was trained in (``trained_dim``); one :class:`~swimrl.errors.ConfigError`
    naming both where they differ."""
    dim = signals_dimension(signals)
    if dim is not None and dim != flow_dim:
        raise ConfigError(
            f"policy={spec!r} was trained on the {dim}D signals {list(signals)} but is probed "
            f"in flow={flow_name}, a {flow_dim}D flow: allowed a {dim}D flow (probe.flow=own "
            f"takes the policy's own)")
    if trained_dim is not None and trained_dim != flow_dim:
        raise ConfigError(
            f"policy={spec!r} was trained in a {trained_dim}D flow but is probed in "
            f"flow={flow_name}, a {flow_dim}D flow: allowed a {trained_dim}D flow "
            "(probe.flow=own takes the policy's own)")
    return flow_dim


@dataclass(frozen=True)
class ProbeSettings:
    """``probe.*`` besides the strategies: the states (``states``, of
    :data:`PROBE_STATES`), the alignment threshold (``n_r_min``, in ``[-1, 1)``: states with
    ``n_r > n_r_min``), the Gaussian sample size and seed (``n_samples``, ``sample_seed``)
    and where a policy runs for the ``flows`` states (``flow``, of :data:`PROBE_FLOWS`)."""

    states: tuple[str, ...]
    n_r_min: float
    n_samples: int
    sample_seed: int
    flow: str

    def __post_init__(self) -> None:
        states = tuple(self.states)
        require(bool(states) and len(set(states)) == len(states), "probe.states", list(states),
                f"a non-empty list of distinct names of {list(PROBE_STATES)}")
        for s in states:
            one_of("probe.states", s, PROBE_STATES)
        object.__setattr__(self, "states", states)
        as_float("probe.n_r_min", self.n_r_min, lambda v: -1 <= v < 1,
                 "a number in [-1, 1) (n_r = n.e_r lies in [-1, 1]; states with n_r > n_r_min)")
        as_int("probe.n_samples", self.n_samples, low=100)
        as_int("probe.sample_seed", self.sample_seed, low=0)
        one_of("probe.flow", self.flow, PROBE_FLOWS)
        keep_number_types(self)


@dataclass(frozen=True)
class Subject:
    """One strategy of the probe: its row ``label``, its spec (``strategy``, and ``policy``
    for a trained policy), the environment parameters it is probed with (``params``: its
    signals, ``Lambda_max``, task), its ``dimension`` and, for the ``flows`` states, the
    evaluation ``setup`` of its trajectories (None where only Gaussian states are probed);
    ``meta``: what the record says of it (the policy file's sha256, ...)."""

    label: str
    strategy: StrategySpec
    params: EnvParams
    dimension: int
    policy: str | None = None
    setup: RunSpec | None = None
    meta: dict | None = None

    def __post_init__(self) -> None:
        if SHAPE_SIGNAL in self.params.signals:
            raise ConfigError(
                f"{self.label} observes its own shape ({SHAPE_SIGNAL!r} in its signals "
                f"{list(self.params.signals)}), which the probe's states do not define: allowed "
                "strategies and policies of the flow signals only")
        self.strategy.check_dimension(self.dimension)
        if self.setup is not None and self.setup.dimension != self.dimension:
            raise ConfigError(f"{self.label} is {self.dimension}D but its flow "
                              f"{self.setup.flow.name} is {self.setup.dimension}D")


@dataclass(frozen=True)
class ProbeConfig:
    """``swimrl-probe``: the subjects, the settings, ``overwrite`` (replace the run
    directory's record) and ``record`` (the resolved config, copied into the record)."""

    subjects: tuple[Subject, ...]
    settings: ProbeSettings
    overwrite: bool
    record: dict

    def __post_init__(self) -> None:
        require(bool(self.subjects), "probe.strategies", [],
                "at least one strategy (naive, sto, minimal, policy with probe.policies)")
        labels = [s.label for s in self.subjects]
        require(len(set(labels)) == len(labels), "probe.policies", labels,
                "distinct strategies and policies")
        if "flows" in self.settings.states:
            for s in self.subjects:
                require(s.setup is not None, "probe.states", list(self.settings.states),
                        f"'flows' with an evaluation setup for {s.label}")


# --- the measurement -----------------------------------------------------------------------


def _corr(x: np.ndarray, y: np.ndarray) -> float | None:
    """Pearson's correlation; None where either is constant or fewer than 3 values."""
    if len(x) < 3 or np.ptp(x) == 0 or np.ptp(y) == 0:
        return None
    return float(np.corrcoef(x, y)[0, 1])


def _num(x) -> float | None:
    return None if x is None or not math.isfinite(x) else float(x)


KEYS = ("lambda_mean", "corr_sto", "corr_star", "corr_sto_star",
        *(f"tumbling_{r}" for r in RATES))


def _values(signals: torch.Tensor, lam: torch.Tensor, shape_factor_max: float,
            independent: bool = False) -> tuple[dict, dict]:
    """The probe's quantities (:data:`KEYS`) of one set of aligned states (signals
    ``(n, d)``, the strategy's ``lam`` ``(n,)``), and, for ``independent`` states, their
    SEMs (else None each)."""
    names = body_of_signals(signals).signal_names
    sto = sto_shape(signals, shape_factor_max)
    star = stabilising_shape(signals, names, shape_factor_max)
    shapes = {"zero": torch.zeros_like(lam), "subject": lam, "sto": sto, "star": star}
    arrays = {"lambda_mean": lam.double().numpy()}
    arrays.update({f"tumbling_{r}": tumbling_rate(signals, names, shapes[r]).double().numpy()
                   for r in RATES})
    n = len(lam)
    values = {k: float(a.mean()) if n else None for k, a in arrays.items()}
    lam_np, sto_np, star_np = (t.double().numpy() for t in (lam, sto, star))
    values.update(corr_sto=_corr(lam_np, sto_np), corr_star=_corr(lam_np, star_np),
                  corr_sto_star=_corr(sto_np, star_np))
    sems = dict.fromkeys(KEYS)
    if independent:
        for k, a in arrays.items():
            sems[k] = float(a.std(ddof=1) / math.sqrt(n)) if n > 1 else None
        for k in ("corr_sto", "corr_star", "corr_sto_star"):
            r = values[k]
            sems[k] = (1 - r * r) / math.sqrt(n - 3) if r is not None and n > 3 else None
    return values, sems


def mechanism_stats(signals: torch.Tensor, lam: torch.Tensor, shape_factor_max: float,
                    n_r_min: float, flows: torch.Tensor | None = None) -> dict:
    """The probe's record of one strategy on one set of states: the states with
    ``n_r > n_r_min`` of ``signals`` ``(n, 5 | 7)`` and the strategy's shape factors ``lam``
    ``(n,)``; ``flows`` ``(n,)``: the flow of each state (SEMs over flows, ``per_flow``), else
    the states are independent (module docstring).

    Returns
    -------
    dict
        ``n_states``, ``n_aligned``, ``fraction_aligned``, ``lambda_mean``, ``corr_sto``,
        ``corr_star``, ``corr_sto_star`` with their SEMs (``*_sem``), ``tumbling``
        (``{zero, subject, sto, star}``: mean rate ``|n'| tau_K`` and SEM); None where
        undefined (a constant strategy's correlations); with ``flows`` also ``per_flow``
        (each quantity per flow).
    """
    signals = signals.double()
    lam = lam.double()
    aligned = signals[:, body_of_signals(signals).signal_names.index("n_r")] > n_r_min
    s, lam_a = signals[aligned], lam[aligned]
    values, sems = _values(s, lam_a, shape_factor_max, independent=flows is None)
    per_flow = None
    if flows is not None:
        fa = flows[aligned]
        ids = torch.unique(flows)
        per_flow = {key: [] for key in ("n_aligned", *KEYS)}
        for f in ids:
            m = fa == f
            vals, _ = _values(s[m], lam_a[m], shape_factor_max)
            per_flow["n_aligned"].append(int(m.sum()))
            for key in KEYS:
                per_flow[key].append(_num(vals[key]))
        for key in KEYS:
            xs = [x for x in per_flow[key] if x is not None]
            sems[key] = (float(np.std(xs, ddof=1) / math.sqrt(len(xs)))
                         if len(xs) > 1 and len(xs) == len(ids) else None)
    n = int(aligned.sum())
    out = {"n_states": int(signals.shape[0]), "n_aligned": n,
           "fraction_aligned": n / max(int(signals.shape[0]), 1)}
    for key in ("lambda_mean", "corr_sto", "corr_star", "corr_sto_star"):
        out[key], out[f"{key}_sem"] = _num(values[key]), _num(sems[key])
    out["tumbling"] = {r: {"mean": _num(values[f"tumbling_{r}"]),
                           "sem": _num(sems[f"tumbling_{r}"])} for r in RATES}
    if per_flow is not None:
        out["per_flow"] = per_flow
    return out


def _actor(subject: Subject) -> torch.nn.Module:
    """The subject's actor: a baseline built against ``Lambda_max``, or the policy's
    deterministic actor (:func:`~swimrl.runs.policy_files.load_policy`, as ``swimrl-compare``
    loads ``compare.policies``)."""
    if subject.strategy.name == "policy":
        return load_policy(str(subject.policy), subject.params)
    spec = action_spec(subject.params.shape_factor_max, dtype=torch.float32)
    return build_strategy(subject.strategy, spec)


def actions(actor, signals: torch.Tensor, params: EnvParams) -> torch.Tensor:
    """The actor's shape factor ``(n,)`` at the signals ``(n, 5 | 7)`` (all of a body's;
    the observation is the actor's subset ``params.signals``), clamped to
    ``[-Lambda_max, Lambda_max]`` as the environment applies it."""
    x = signals.to(torch.float32)
    obs = observable(body_of_signals(x), x, params.signals)
    td = TensorDict({"signals": x, "observation": obs}, batch_size=[x.shape[0]])
    with torch.no_grad():
        lam = actor(td).get("action")[..., 0]
    lam_max = params.shape_factor_max
    return lam.double().clamp(-lam_max, lam_max)


def _same_flows(a: Subject, b: Subject) -> bool:
    """Whether ``a`` and ``b`` can share one evaluation's flows: the same flow, runtime,
    sizes, seed and parameters but the reward (which changes no trajectory)."""
    def key(s: Subject):
        st = s.setup
        return (st.flow, st.runtime, st.sizes, st.seed, replace(s.params, reward=RewardSpec()))
    return key(a) == key(b)


def recorded_states(setup: RunSpec, actors: Sequence, params: EnvParams) -> list[dict]:
    """Every decision of every swimmer of an evaluation of ``actors`` on ``setup`` (shared
    flows, the same starts): per actor ``signals`` ``(m, 5 | 7)``, ``Lambda`` ``(m,)`` (as
    applied), ``flow`` ``(m,)`` of the decisions kept (module docstring) and the actor's
    ``R_hat`` (mean and SEM over flows)."""
    sizes = setup.sizes
    recorder = TrajectoryRecorder(sizes.n_swimmers)
    metrics = evaluate_shared(setup, list(actors), desc="probe", recorder=recorder)
    arr = recorder.arrays()
    sig = torch.from_numpy(arr["signals"])  # (F, K, n, N, d)
    lam = torch.from_numpy(arr["Lambda"])   # (F, K, n, N)
    f, k, n, n_dec = lam.shape
    keep = torch.ones(f, k, n, n_dec, dtype=torch.bool)
    keep[..., 0] = False  # at the start e_r := n, a convention
    if "arrival_time" in arr:
        t = torch.arange(n_dec, dtype=torch.float64) * params.update_interval
        arrived = torch.from_numpy(np.asarray(arr["arrival_time"], dtype=np.float64))
        keep &= ~(t >= arrived.nan_to_num(nan=math.inf)[..., None])
    flow_id = torch.arange(f)[:, None, None, None].expand(f, k, n, n_dec)
    out = []
    for j in range(k):
        m = keep[:, j]
        out.append({"signals": sig[:, j][m].double(), "Lambda": lam[:, j][m].double(),
                    "flow": flow_id[:, j][m],
                    "R_hat_mean": metrics[j]["R_hat_mean"], "R_hat_sem": metrics[j]["R_hat_sem"],
                    "swimmer_substeps_per_s": metrics[j]["swimmer_substeps_per_s"]})
    return out


def _row(subject: Subject, states: str, stats: dict) -> dict:
    flow = subject.setup.record["flow"] if states == "flows" else None
    return {"label": subject.label, "strategy": subject.strategy.name,
            "policy": subject.policy, "dimension": subject.dimension,
            "signals": list(subject.params.signals), "task": subject.params.task.name,
            "flow": flow, "flow_label": ku_name(flow) if flow else None,
            **(subject.meta or {}), "states": states, **stats}


def run_probe(cfg: ProbeConfig, log=None) -> dict:
    """The probe of every subject on the states of ``cfg.settings`` (module docstring).

    Returns
    -------
    dict
        The record: ``n_r_min``, ``states``, the Gaussian sample (``gaussian``), the
        evaluations of the ``flows`` states (``flows``), ``rows`` (one per subject and kind
        of states: :func:`mechanism_stats` with the subject's label, spec, dimension,
        signals, task, flow and, for ``flows``, its ``R_hat``), ``wall_s`` and ``config``.
    """
    t0 = time.perf_counter()
    st = cfg.settings
    actors = [_actor(s) for s in cfg.subjects]
    rows: list[dict] = []
    record: dict = {"n_r_min": st.n_r_min, "states": list(st.states)}
    if "gaussian" in st.states:
        samples = {d: gaussian_states(d, st.n_samples, st.sample_seed)
                   for d in sorted({s.dimension for s in cfg.subjects})}
        record["gaussian"] = {"n_samples": st.n_samples, "sample_seed": st.sample_seed,
                              "tau_K": 1.0, "dimensions": sorted(samples)}
        for subject, actor in zip(cfg.subjects, actors, strict=True):
            g = samples[subject.dimension]
            lam = actions(actor, g.signals, subject.params)
            stats = mechanism_stats(g.signals, lam, subject.params.shape_factor_max,
                                    st.n_r_min)
            rows.append(_row(subject, "gaussian", stats))
    if "flows" in st.states:
        groups: list[list[int]] = []
        for i, s in enumerate(cfg.subjects):
            home = next((grp for grp in groups if _same_flows(cfg.subjects[grp[0]], s)), None)
            if home is None:
                groups.append([i])
            else:
                home.append(i)
        runs = []
        for grp in groups:
            first = cfg.subjects[grp[0]]
            if log is not None:
                log(f"flows: {', '.join(cfg.subjects[i].label for i in grp)} on "
                    f"{ku_name(first.setup.record['flow'])}")
            rec = recorded_states(first.setup, [actors[i] for i in grp], first.params)
            sizes = first.setup.sizes
            runs.append({"labels": [cfg.subjects[i].label for i in grp],
                         "flow": first.setup.record["flow"], "n_flows": sizes.n_flows,
                         "n_swimmers": sizes.n_swimmers, "seed": first.setup.seed,
                         "swimmer_substeps_per_s": rec[0]["swimmer_substeps_per_s"]})
            for i, r in zip(grp, rec, strict=True):
                s = cfg.subjects[i]
                stats = mechanism_stats(r["signals"], r["Lambda"], s.params.shape_factor_max,
                                        st.n_r_min, r["flow"])
                rows.append(_row(s, "flows", {"R_hat_mean": r["R_hat_mean"],
                                              "R_hat_sem": r["R_hat_sem"], **stats}))
        record["flows"] = {"evaluations": runs, "decisions": "every decision but the first "
                           "(and none after arrival with task=target)"}
    order = {s.label: i for i, s in enumerate(cfg.subjects)}
    rows.sort(key=lambda r: (PROBE_STATES.index(r["states"]), order[r["label"]]))
    record["rows"] = rows
    record["wall_s"] = time.perf_counter() - t0
    record["config"] = cfg.record
    return record
