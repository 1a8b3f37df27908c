r"""Load a trained policy for ``swimrl-eval strategy=policy policy=SPEC``.

``SPEC`` is one of

* a training run directory (its ``policy.pt``, else its ``checkpoints/last.pt``);
* a checkpoint or policy file written by ``swimrl-train``;
* ``pretrained/NAME``: the policy shipped in the package under ``swimrl/pretrained/NAME/``
  (short names ``ku0.1``, ``ku1``, ``ku10``, ``ku1e7``: trained at that Kubo number with all
  five signals; ``ku1e+07`` or ``ku10000000`` also find ``ku1e7``).

The result is a deterministic actor (``Lambda = Lambda_max tanh(mu(s))``, the mean of the
trained Gaussian pushed through the bounding ``tanh``) that reads ``observation`` and writes
``action``. The policy's signal set (stored in the file) must equal ``signals.names`` of the
evaluation config, otherwise a :class:`~swimrl.config.ConfigError` names both sets and the
``signals=...`` choice that matches.
"""

from __future__ import annotations

from pathlib import Path

import torch
from tensordict.nn import TensorDictModule

from swimrl.config import ConfigError, EnvParams
from swimrl.paths import CONF_DIR
from swimrl.rl.checkpoint import CHECKPOINT_FORMAT, POLICY_FORMAT, checkpoint_path, load_file
from swimrl.rl.models import deterministic_actor, make_actor

#: Where ``pretrained/NAME`` is looked up (one sub-directory per policy).
PRETRAINED_ROOT = Path(__file__).resolve().parent / "pretrained"
PRETRAINED_PREFIX = "pretrained/"
SHORT_NAMES = ("ku0.1", "ku1", "ku10", "ku1e7")


def available_pretrained(root: Path | None = None) -> list[str]:
    """Names of the pretrained policies installed under ``root``."""
    root = PRETRAINED_ROOT if root is None else Path(root)
    if not root.is_dir():
        return []
    return sorted(d.name for d in root.iterdir() if d.is_dir() and _policy_file(d) is not None)


def _kubo_value(name: str) -> float | None:
    if not name.lower().startswith("ku"):
        return None
    try:
        return float(name[2:])
    except ValueError:
        return None


def _policy_file(directory: Path) -> Path | None:
    for candidate in (directory / "policy.pt", checkpoint_path(directory)):
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
        if match is None and _kubo_value(name) is not None:
            match = next((n for n in names if _kubo_value(n) == _kubo_value(name)), None)
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
    from omegaconf import OmegaConf

    for f in sorted((CONF_DIR / "signals").glob("*.yaml")):
        if list(OmegaConf.load(f).get("names", [])) == list(names):
            return f"signals={f.stem}"
    return "signals.names=[" + ",".join(names) + "]"


def check_signals(spec: str, trained: list[str], params: EnvParams) -> None:
    """Raise a one-line ConfigError if the policy's signals differ from ``params.signals``."""
    if tuple(trained) != tuple(params.signals):
        raise ConfigError(
            f"signals.names={list(params.signals)} does not match policy={spec!r}, which was "
            f"trained on {list(trained)}: evaluate it with {signals_choice(trained)}"
        )


def load_policy(spec: str, params: EnvParams) -> TensorDictModule:
    """Deterministic actor ``observation -> action`` of the policy named by ``spec``."""
    path = resolve_policy_file(spec)
    data = load_file(path, map_location="cpu")
    if not isinstance(data, dict) or data.get("format") not in (CHECKPOINT_FORMAT, POLICY_FORMAT):
        raise ValueError(f"policy={spec!r}: {path} is not a swimrl-train policy or checkpoint")
    check_signals(spec, data["signals"], params)
    model = data["model"]
    dtype = getattr(torch, str(model.get("dtype", "float32")))
    actor = make_actor(
        int(model["n_obs"]),
        float(model["shape_factor_max"]),
        hidden=[int(h) for h in model["hidden"]],
        activation=str(model["activation"]),
        init_std=float(model.get("init_std", 1.0)),
        dtype=dtype,
    )
    actor.load_state_dict(data["actor"])
    actor.requires_grad_(False)
    policy = deterministic_actor(actor, float(model["shape_factor_max"]))
    return policy.eval()
