r"""Policy files: the format written by ``swimrl-train`` and the loader behind
``swimrl-eval strategy=policy policy=SPEC``.

A run directory (its files: :class:`RunLayout`) holds ``policy.pt`` (the final actor +
metadata) and ``checkpoints/last.pt`` (the full training state, :mod:`swimrl.runs.checkpoint`);
both are written atomically (:func:`swimrl.runs.atomic.atomic_write`) and hold tensors and plain
containers only. ``SPEC`` is one of

* a training run directory (its ``policy.pt``, else its ``checkpoints/last.pt``);
* a checkpoint or policy file written by ``swimrl-train``;
* ``pretrained/NAME``: the policy shipped in the package under
  ``swimrl/policies/pretrained/NAME/``
  (short names ``ku0.1``, ``ku1``, ``ku10``, ``ku1e7``: trained at that Kubo number with all
  five signals; ``ku1e+07`` or ``ku10000000`` also find ``ku1e7``).

The result is a deterministic actor (``Lambda = Lambda_max tanh(mu(s))``, the mean of the
trained Gaussian pushed through the bounding ``tanh``; for a steering action the same per
component, or the most probable of the discrete directions) that reads ``observation`` and
writes ``action``. The policy's signal set (stored in the file) must equal ``signals.names``
of the evaluation config, otherwise a :class:`~swimrl.config.ConfigError` names both sets and
the ``signals=...`` choice that matches; likewise its actuation (``actuation.*``) and, given
the environment's action spec, the action's form (:func:`~swimrl.policies.networks.check_action`:
a 2D steering policy in a 3D flow is refused with one line). The file records the action spec
(``action``: ``kind`` ``bounded`` or ``categorical``, ``width``, ``low``, ``high``); a file
written before records none and is a shape-factor policy.
"""

from __future__ import annotations

import dataclasses
import hashlib
import importlib.resources
from pathlib import Path

import torch
import yaml
from tensordict.nn import TensorDictModule
from torchrl.data import Bounded, Categorical

from swimrl.actuation import ActuationSpec
from swimrl.env import EnvParams
from swimrl.errors import BadFileError, ConfigError
from swimrl.flows.labels import parse_ku_name
from swimrl.physics.body2d import SIGNAL_NAMES
from swimrl.physics.body3d import SIGNAL_NAMES_3D
from swimrl.policies.networks import (
    NO_STD_BOUND,
    ModelSpec,
    action_spec,
    action_width,
    categorical_actor,
    check_action,
    deterministic_actor,
    tanh_normal_actor,
)
from swimrl.runs.atomic import atomic_write
from swimrl.runs.layout import RunLayout

CHECKPOINT_FORMAT = "swimrl-ppo-checkpoint/1"
POLICY_FORMAT = "swimrl-ppo-policy/1"

#: Where ``pretrained/NAME`` is looked up (one sub-directory per policy).
PRETRAINED_ROOT = Path(__file__).resolve().parents[1] / "policies" / "pretrained"
PRETRAINED_PREFIX = "pretrained/"
SHORT_NAMES = ("ku0.1", "ku1", "ku10", "ku1e7")


def load_file(path: Path, map_location="cpu") -> dict:
    """Load a checkpoint or policy file (tensors and plain containers only: ``weights_only``).

    A file that is truncated, corrupt, not a torch file or not a swimrl-train file, or whose
    actor or critic weights are not all finite, raises :class:`~swimrl.errors.BadFileError`
    naming its path.
    """
    path = Path(path)
    try:
        data = torch.load(path, map_location=map_location, weights_only=True)
    except FileNotFoundError:
        raise
    except Exception as err:  # noqa: BLE001 - torch raises many types for a bad file
        reason = (str(err).strip().splitlines() or [type(err).__name__])[0][:120]
        raise BadFileError(f"{path} cannot be read as a swimrl-train policy or checkpoint "
                           f"(truncated, corrupt or another kind of file: {reason})") from err
    if not isinstance(data, dict) or data.get("format") not in (CHECKPOINT_FORMAT, POLICY_FORMAT):
        raise BadFileError(f"{path} is not a swimrl-train policy or checkpoint")
    for part in ("actor", "critic"):
        for name, value in (data.get(part) or {}).items():
            if torch.is_tensor(value) and value.is_floating_point() and not bool(
                    torch.isfinite(value).all()):
                raise BadFileError(
                    f"{path} holds non-finite weights ({part} {name}: "
                    f"{int((~torch.isfinite(value)).sum())} of {value.numel()} NaN or inf): "
                    "refusing to use it")
    return data


def env_params_dict(params: EnvParams) -> dict:
    """Constructor arguments of ``params`` as plain Python values (the task and reward specs
    as dicts)."""
    out = {}
    for f in dataclasses.fields(params):
        if f.init:
            v = getattr(params, f.name)
            if dataclasses.is_dataclass(v):
                v = dataclasses.asdict(v)
            out[f.name] = list(v) if isinstance(v, tuple) else v
    return out


def action_record(spec: Bounded | Categorical) -> dict:
    """The action spec ``spec`` (unbatched) as plain values: ``kind`` (``bounded`` or
    ``categorical``), ``width`` (components or choices), and for a bounded one ``low`` and
    ``high`` per component (:func:`action_from_record` rebuilds it)."""
    if isinstance(spec, Categorical):
        return {"kind": "categorical", "width": action_width(spec)}
    m = action_width(spec)
    return {"kind": "bounded", "width": m,
            "low": [float(v) for v in spec.space.low.reshape(-1, m)[0]],
            "high": [float(v) for v in spec.space.high.reshape(-1, m)[0]]}


def action_from_record(data: dict, dtype=torch.float32) -> Bounded | Categorical:
    """The unbatched action spec of a policy file's ``data`` (:func:`action_record`); a file
    without one is a shape-factor policy, ``[-Lambda_max, Lambda_max]`` of its
    ``model.shape_factor_max``, as is a bounded width-1 record."""
    record = data.get("action")
    if record is None or (record["kind"] == "bounded" and int(record["width"]) == 1):
        return action_spec(float(data["model"]["shape_factor_max"]), dtype=dtype)
    if record["kind"] == "categorical":
        return Categorical(int(record["width"]), shape=(), dtype=torch.int64)
    low = torch.tensor([float(v) for v in record["low"]], dtype=dtype)
    high = torch.tensor([float(v) for v in record["high"]], dtype=dtype)
    return Bounded(low=low, high=high, shape=(int(record["width"]),), dtype=dtype)


def policy_meta(params: EnvParams, model: ModelSpec, dtype: str,
                action: Bounded | Categorical | None = None) -> dict:
    """What is needed to rebuild the actor and check it against an evaluation config;
    ``action``: the environment's unbatched action spec (None: the shape factor's of
    ``params``, the only one known without the flow's dimension; ValueError for a steering
    ``params.actuation``)."""
    if action is None:
        if params.actuation.steers:
            raise ValueError(f"policy_meta: actuation={params.actuation.name} needs the "
                             "environment's action spec (action=env.action_spec_unbatched)")
        action = action_spec(params.shape_factor_max)
    return {
        "signals": list(params.signals),
        "env_params": env_params_dict(params),
        "model": {
            "n_obs": len(params.signals),
            "hidden": list(model.hidden),
            "activation": model.activation,
            "init_std": model.init_std,
            "min_std": model.min_std,
            "shape_factor_max": float(params.shape_factor_max),
            "dtype": str(dtype),
        },
        "action": action_record(action),
    }


def save_policy(path: Path, *, actor, counters: dict, config: dict, meta: dict) -> Path:
    """Export the actor (all its parameters, incl. ``log sigma``) with its metadata
    (``torch.save``, atomically, making the directory)."""
    data = {
        "format": POLICY_FORMAT,
        "actor": actor.state_dict(),
        "counters": dict(counters),
        "config": config,
        **meta,
    }
    return atomic_write(path, lambda fh: torch.save(data, fh), make_dirs=True)


def sha256_file(path: Path) -> str:
    """sha256 (hex) of a file's bytes: how records name the exact policy file they used."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def available_pretrained(root: Path | None = None) -> list[str]:
    """Names of the pretrained policies installed under ``root``."""
    root = PRETRAINED_ROOT if root is None else Path(root)
    if not root.is_dir():
        return []
    return sorted(d.name for d in root.iterdir() if d.is_dir() and _policy_file(d) is not None)


def _policy_file(directory: Path) -> Path | None:
    run = RunLayout(directory)
    for candidate in (run.policy, run.checkpoint):
        if candidate.is_file():
            return candidate
    return None


def resolve_policy_file(spec: str) -> Path:
    """The file behind a policy spec (see the module docstring); clear errors otherwise."""
    spec = str(spec)
    if spec.startswith(PRETRAINED_PREFIX):
        name = spec[len(PRETRAINED_PREFIX) :].strip("/")
        names = available_pretrained()
        match = name if name in names else None
        kubo = parse_ku_name(name)
        if match is None and kubo is not None:
            match = next((n for n in names if parse_ku_name(n) == kubo), None)
        if match is None:
            have = ", ".join(names) if names else "none installed yet"
            raise FileNotFoundError(
                f"policy={spec!r}: no pretrained policy {name!r} in {PRETRAINED_ROOT} "
                f"(available: {have}; short names {', '.join(SHORT_NAMES)})"
            )
        return _policy_file(PRETRAINED_ROOT / match)
    path = Path(spec).expanduser()
    if path.is_dir():
        found = _policy_file(path)
        if found is None:
            raise FileNotFoundError(
                f"policy={spec!r}: no policy.pt or checkpoints/last.pt in this directory"
            )
        return found
    if path.is_file():
        return path
    raise FileNotFoundError(
        f"policy={spec!r}: no such run directory or checkpoint file (or use pretrained/NAME)"
    )


def signals_choice(names) -> str:
    """``signals=<group>`` whose ``conf/signals/<group>.yaml`` lists ``names``, else
    ``signals.names=[...]``."""
    if tuple(names) in (SIGNAL_NAMES, SIGNAL_NAMES_3D):  # signals=all: the flow's whole set
        return "signals=all"
    groups = importlib.resources.files("swimrl.conf") / "signals"
    for f in sorted(groups.iterdir(), key=lambda f: f.name):
        if f.name.endswith(".yaml") and yaml.safe_load(f.read_text()).get("names") == list(names):
            return f"signals={f.name[: -len('.yaml')]}"
    return "signals.names=[" + ",".join(names) + "]"


def check_signals(spec: str, trained: list[str], signals: tuple[str, ...]) -> None:
    """Raise a one-line ConfigError if the policy's signals differ from ``signals``."""
    if tuple(trained) != tuple(signals):
        raise ConfigError(
            f"signals.names={list(signals)} does not match policy={spec!r}, which was "
            f"trained on {list(trained)}: evaluate it with {signals_choice(trained)}"
        )


def trained_actuation(data: dict) -> ActuationSpec:
    """The actuation a policy file's ``data`` was trained with (``env_params.actuation``;
    ``shape`` for a file written before actuations existed)."""
    saved = data.get("env_params", {}).get("actuation") or {}
    return ActuationSpec(**{k: saved[k] for k in ("name", "directions") if k in saved})


def actuation_choice(actuation: ActuationSpec) -> str:
    """``actuation=NAME`` (and ``actuation.directions=discrete`` where so)."""
    text = f"actuation={actuation.name}"
    if actuation.steers and actuation.directions == "discrete":
        text += " actuation.directions=discrete"
    return text


def check_actuation(spec: str, data: dict, actuation: ActuationSpec) -> None:
    """Raise a one-line ConfigError if the policy (file content ``data``) was trained with
    another actuation (name, or steering directions) than ``actuation``."""
    trained = trained_actuation(data)
    have, want = actuation_choice(trained), actuation_choice(actuation)
    if have != want:
        raise ConfigError(f"{want} does not match policy={spec!r}, which was trained with "
                          f"{have}: evaluate it with {have}")


def initial_actor_weights(spec: str, params: EnvParams, model) -> tuple[Path, dict]:
    """The file and actor weights of ``train.init_policy=spec`` (a warm start), checked
    against the run: the same signals (``params.signals``) and the same network
    (``model.hidden``, ``model.activation``: a :class:`~swimrl.policies.networks.ModelSpec`);
    a one-line :class:`~swimrl.errors.ConfigError` naming ``train.init_policy`` otherwise."""
    try:
        path = resolve_policy_file(spec)
    except FileNotFoundError as err:
        raise ConfigError(f"train.init_policy: {err}") from None
    data = load_file(path, map_location="cpu")
    try:
        check_signals(spec, data["signals"], params.signals)
        check_actuation(spec, data, params.actuation)
    except ConfigError as err:
        raise ConfigError(f"train.init_policy: {err}") from None
    saved = data["model"]
    have = ([int(h) for h in saved["hidden"]], str(saved["activation"]))
    want = ([int(h) for h in model.hidden], str(model.activation))
    if have != want:
        raise ConfigError(
            f"train.init_policy={spec!r} has hidden={have[0]}, activation={have[1]!r}; the run "
            f"builds model.hidden={want[0]}, model.activation={want[1]!r}: set those to match"
        )
    return path, data["actor"]


def load_policy(spec: str, params: EnvParams,
                action: Bounded | Categorical | None = None) -> TensorDictModule:
    """Deterministic actor ``observation -> action`` of the policy named by ``spec``, checked
    against the evaluation's signals ``params.signals`` and actuation ``params.actuation``
    (and, where given, the environment's action spec ``action``). The actor keeps the bound
    ``Lambda_max`` it was trained with (the environment clamps to its own).

    Parameters
    ----------
    spec
        ``pretrained/NAME`` (a shipped policy: ``ku0.1``, ``ku1``, ``ku10``, ``ku1e7``,
        ``dns``), a run directory (its ``policy.pt``, else ``checkpoints/last.pt``) or a
        policy or checkpoint file.
    params
        The environment's parameters: its ``signals`` must be those the policy was trained
        on (else a one-line :class:`~swimrl.errors.ConfigError` naming the right
        ``signals=`` choice), its ``actuation`` the policy's (else one line naming it).
    action
        The environment's ``action_spec_unbatched`` (None: not checked here; an evaluation
        checks it, :func:`~swimrl.policies.networks.check_action`): a one-line
        ConfigError where the policy acts otherwise (e.g. trained in a 2D flow, evaluated in
        a 3D one).

    Returns
    -------
    TensorDictModule
        The actor's mean, ``tanh``-bounded (a discrete action: its most probable choice), in
        evaluation mode without gradients: the policy of TorchRL's ``env.rollout(n,
        policy)``. Its ``action_spec`` is the action spec it was trained with.

    Raises
    ------
    FileNotFoundError
        No such policy.
    """
    path = resolve_policy_file(spec)
    data = load_file(path, map_location="cpu")
    check_signals(spec, data["signals"], params.signals)
    check_actuation(spec, data, params.actuation)
    model = data["model"]
    dtype = getattr(torch, str(model.get("dtype", "float32")))
    trained = action_from_record(data, dtype)
    if action is not None:
        check_action(trained, action, f"policy={spec!r}")
    shape = {"hidden": [int(h) for h in model["hidden"]],
             "activation": str(model["activation"]), "dtype": dtype}
    if isinstance(trained, Categorical):
        actor = categorical_actor(int(model["n_obs"]), trained, **shape)
    else:
        actor = tanh_normal_actor(int(model["n_obs"]), trained,
                                  init_std=float(model.get("init_std", 1.0)),
                                  min_std=float(model.get("min_std", NO_STD_BOUND)), **shape)
    actor.load_state_dict(data["actor"])
    actor.requires_grad_(False)
    policy = deterministic_actor(actor)
    policy.source = f"policy={spec!r}"
    return policy.eval()
