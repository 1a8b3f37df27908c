r"""Atomic checkpoints of a training run, and the exported policy.

Layout of a run directory::

    <run>/checkpoints/last.pt   full training state (this module), replaced atomically
    <run>/policy.pt             the final actor + metadata (what ``load_policy`` prefers)
    <run>/metrics.json          final held-out evaluation (the run is finished when it exists)
    <run>/tb/ppo/               TensorBoard events

``last.pt`` holds actor, critic, both Adam optimisers and LR schedulers, the RNG states
(torch CPU [+ CUDA] global generator, which drives action sampling and minibatch
shuffling, and the environment's generator, which drives flows and initial conditions),
the counters (frames, updates, episodes, wall time), the resolved config, the signal
names, the env parameters and the network shape. Files are written to ``*.tmp`` and moved
with :func:`os.replace`, so a kill at any moment (even ``kill -9``) leaves either the
previous or the new checkpoint, never a truncated one.
"""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path

import torch

from swimrl.config import EnvParams

CHECKPOINT_FORMAT = "swimrl-ppo-checkpoint/1"
POLICY_FORMAT = "swimrl-ppo-policy/1"


def checkpoint_path(run_dir: Path) -> Path:
    return Path(run_dir) / "checkpoints" / "last.pt"


def policy_path(run_dir: Path) -> Path:
    return Path(run_dir) / "policy.pt"


def atomic_save(obj, path: Path) -> Path:
    """``torch.save`` to ``path.tmp``, flush to disk, then ``os.replace`` onto ``path``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "wb") as fh:
        torch.save(obj, fh)
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)
    return path


def env_params_dict(params: EnvParams) -> dict:
    """Constructor arguments of ``params`` as plain Python values."""
    out = {}
    for f in dataclasses.fields(params):
        if f.init:
            v = getattr(params, f.name)
            out[f.name] = list(v) if isinstance(v, tuple) else v
    return out


def policy_meta(cfg, params: EnvParams) -> dict:
    """What is needed to rebuild the actor and check it against an evaluation config."""
    return {
        "signals": list(params.signals),
        "env_params": env_params_dict(params),
        "model": {
            "n_obs": len(params.signals),
            "hidden": [int(h) for h in cfg.model.hidden],
            "activation": str(cfg.model.activation),
            "init_std": float(cfg.model.init_std),
            "shape_factor_max": float(params.shape_factor_max),
            "dtype": str(cfg.dtype),
        },
    }


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
    path: Path,
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
    """Write the full training state atomically."""
    return atomic_save(
        {
            "format": CHECKPOINT_FORMAT,
            "actor": actor.state_dict(),
            "critic": critic.state_dict(),
            "optimizers": [o.state_dict() for o in optimizers],
            "schedulers": [s.state_dict() for s in schedulers],
            "rng": rng,
            "counters": dict(counters),
            "config": config,
            **meta,
        },
        path,
    )


def save_policy(path: Path, *, actor, counters: dict, config: dict, meta: dict) -> Path:
    """Export the actor (all its parameters, incl. ``log sigma``) with its metadata."""
    return atomic_save(
        {
            "format": POLICY_FORMAT,
            "actor": actor.state_dict(),
            "counters": dict(counters),
            "config": config,
            **meta,
        },
        path,
    )


def load_file(path: Path, map_location="cpu") -> dict:
    """Load a checkpoint or policy file (tensors and plain containers only)."""
    return torch.load(Path(path), map_location=map_location, weights_only=True)
