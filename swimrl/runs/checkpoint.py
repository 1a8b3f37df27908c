r"""Atomic checkpoints of a training run (the exported policy: :mod:`swimrl.runs.policy_files`).

The files of a run directory (:class:`~swimrl.runs.layout.RunLayout`)::

    <run>/checkpoints/last.pt   full training state (this module), replaced atomically
    <run>/checkpoints/prev.pt   the checkpoint before it (resumed from if last.pt is corrupt)
    <run>/policy.pt             the final actor + metadata (what ``load_policy`` prefers)
    <run>/metrics.json          final held-out evaluation (the run is finished when it exists)
    <run>/tb/ppo/               TensorBoard events

``last.pt`` holds actor, critic, both Adam optimisers and LR schedulers, the RNG states
(torch CPU [+ CUDA] global generator, which drives action sampling and minibatch
shuffling, and the environment's generator, which drives flows and initial conditions),
the counters (frames, updates, episodes, wall time), the resolved config, the signal
names, the env parameters and the network shape. Files are written atomically
(:func:`swimrl.runs.atomic.atomic_write`: a temporary file, ``fsync``, :func:`os.replace`), so a
kill at any moment (even ``kill -9``) leaves either the previous or the new checkpoint, never
a truncated one. The previous ``last.pt`` is kept as ``prev.pt`` (a hard link made before the
replacement, so ``last.pt`` always exists): a
``last.pt`` damaged later (a full disk, a copy cut short) is reported by path and the run
resumes from ``prev.pt`` (:func:`load_checkpoint`).
"""

from __future__ import annotations

import logging
import os
from pathlib import Path

import torch

from swimrl.errors import BadFileError
from swimrl.policies.networks import NO_STD_BOUND
from swimrl.runs.atomic import atomic_write, temp_path
from swimrl.runs.layout import RunLayout
from swimrl.runs.policy_files import CHECKPOINT_FORMAT, load_file

log = logging.getLogger(__name__)

#: Config keys renamed since a checkpoint may have been written: old key -> new key.
LEGACY_KEYS = {
    "episode.shape_factor_max": "swimmer.shape_factor_max",
    "flow.spinup_time": "flow.spinup.time",
    "flow.measure_time": "flow.spinup.measure_time",
    "flow.snapshot_tau_k": "flow.interval_tau_k",
}
#: Keys added later, with the value that reproduces what the code did before they existed
#: (stochastic flow: the readings of the paper's specification, conf/flow/stochastic.yaml;
#: replay: decoding on the run's grid, one start per flow; every flow: no bound on sigma,
#: the learning rates as given).
ADDED_KEYS = {
    "*": {"model.min_std": NO_STD_BOUND,  # every flow
          "train.stagger": 1,
          "train.init_policy": None,  # random initialisation
          "train.actor_frozen_updates": 0,
          "train.critic_flow": False,  # the critic on the policy's observation
          "optim.lr_scale": "none",  # the rates as given
          "optim.lr_reference_minibatch": 2560,
          "task": {"name": "displacement", "distance": 20.0, "arrival_radius": 1.0},
          "reward": {"energy_weight": 0.0, "shape_change_weight": 0.0},
          "reward.progress": "distance",
          "task.burn_in": 100.0,  # task=vertical's (not read by the others)
          "swimmer.bottom_heaviness": None,  # no gyrotaxis
          "swimmer.phi": None,
          "swimmer.psi": None,
          "actuation": {"name": "shape", "directions": "continuous", "shape_factor": 0.0}},
    "stochastic": {
        "flow.amplitudes": "stationary",
        "flow.basis": "redrawn",
        "flow.basis_seed": 0,
        "flow.velocity_scale": "total",
    },
    "dns_replay": {"flow.decode_n": None, "flow.flows_per_start": 1},
}


def _rollout_length(train: dict) -> None:
    """``train.frames_per_batch`` (the input before ``train.rollout_length``) ->
    ``rollout_length = frames_per_batch / (n_flows n_swimmers)``."""
    if "frames_per_batch" in train and "rollout_length" not in train:
        batch = int(train["n_flows"]) * int(train["n_swimmers"])
        train["rollout_length"] = int(train.pop("frames_per_batch")) // batch
    train.pop("frames_per_batch", None)


def upgrade_config(config: dict) -> dict:
    """A checkpoint's stored config with renamed keys (:data:`LEGACY_KEYS`) moved to their
    current names, ``train.frames_per_batch`` stated as ``train.rollout_length`` (the same
    batch), and keys added since (:data:`ADDED_KEYS`) set to the value that reproduces the
    old behaviour; the values present are unchanged."""
    out = _copy(config)
    if isinstance(out.get("train"), dict):
        _rollout_length(out["train"])
    flow = out.get("flow") if isinstance(out.get("flow"), dict) else None
    added = {**ADDED_KEYS["*"], **ADDED_KEYS.get(flow.get("name") if flow else None, {})}
    for key, value in added.items():
        *path, last = key.split(".")
        node = _node(out, path)
        if node is not None:
            node.setdefault(last, _copy(value))
    for old, new in LEGACY_KEYS.items():
        *path, last = old.split(".")
        parent = _node(out, path)
        if parent is None or last not in parent:
            continue
        value = parent.pop(last)
        *path, last = new.split(".")
        node = out
        for part in path:
            node = node.setdefault(part, {})
        node.setdefault(last, value)
    return out


def _copy(d):
    return {k: _copy(v) for k, v in d.items()} if isinstance(d, dict) else d


def _node(d: dict, path: list[str]) -> dict | None:
    for part in path:
        d = d.get(part) if isinstance(d, dict) else None
    return d if isinstance(d, dict) else None


def capture_rng(env_generator: torch.Generator) -> dict:
    """RNG states: torch global CPU (+ CUDA if initialised) and the env's generator."""
    state = {"torch": torch.get_rng_state(), "env": env_generator.get_state()}
    if torch.cuda.is_available() and torch.cuda.is_initialized():
        state["cuda"] = torch.cuda.get_rng_state_all()
    return state


def restore_rng(state: dict, env_generator: torch.Generator) -> None:
    torch.set_rng_state(state["torch"])
    env_generator.set_state(state["env"])
    if "cuda" in state and torch.cuda.is_available():
        torch.cuda.set_rng_state_all(state["cuda"])


def save_checkpoint(
    run: RunLayout,
    *,
    actor,
    critic,
    optimizers,
    schedulers,
    rng: dict,
    counters: dict,
    config: dict,
    meta: dict,
) -> Path:
    """Write the full training state atomically to ``run.checkpoint``; the previous one
    becomes ``run.prev_checkpoint``."""
    path = run.checkpoint
    if path.exists():
        prev = run.prev_checkpoint
        tmp = temp_path(prev)
        tmp.unlink(missing_ok=True)
        os.link(path, tmp)
        os.replace(tmp, prev)
    data = {
        "format": CHECKPOINT_FORMAT,
        "actor": actor.state_dict(),
        "critic": critic.state_dict(),
        "optimizers": [o.state_dict() for o in optimizers],
        "schedulers": [s.state_dict() for s in schedulers],
        "rng": rng,
        "counters": dict(counters),
        "config": config,
        **meta,
    }
    return atomic_write(path, lambda fh: torch.save(data, fh), make_dirs=True)


def load_checkpoint(run_dir: Path, map_location="cpu") -> tuple[Path, dict]:
    """``(path, state)`` of the newest readable checkpoint of ``run_dir``: ``last.pt``, or
    ``prev.pt`` (with a warning naming the bad ``last.pt``) if ``last.pt`` is corrupt."""
    run = RunLayout(run_dir)
    last = run.checkpoint
    try:
        return last, load_file(last, map_location)
    except BadFileError as err:
        prev = run.prev_checkpoint
        if not prev.exists():
            raise BadFileError(f"{err}; no prev.pt to fall back to: delete {last} to start "
                               "again, or pass overwrite=true") from err
        try:
            state = load_file(prev, map_location)
        except BadFileError as err2:
            raise BadFileError(f"{last} and {prev} are both unreadable ({err2}); pass "
                               "overwrite=true to start again") from err2
        log.warning("%s; resuming from the previous checkpoint %s", err, prev)
        return prev, state
