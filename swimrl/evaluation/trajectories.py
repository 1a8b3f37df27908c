r"""Trajectory records: every decision of chosen swimmers of an evaluation (``eval.record``).

A :class:`TrajectoryRecorder` passed to :func:`~swimrl.evaluation.rollout.evaluate_shared`
keeps, for the first ``n`` swimmers of every flow and of every strategy block, at each
decision ``i = 0 .. N-1`` (time ``t_i = i T_u``) the five signals and the action ``Lambda``,
and at ``t_0 .. t_N`` the unwrapped position ``x = x_0 + (x - x_0)`` and the orientation
angle ``theta``. The recorded swimmers are the evaluation's own (same flows, same initial
conditions, same rollout), so ``|x(T) - x_0| / (v_s T)`` of a recorded swimmer is the
``R_hat`` that enters the evaluation's statistics.

The arrays (:meth:`TrajectoryRecorder.arrays`), with ``F`` flows, ``K`` strategies, ``n``
swimmers and ``N`` decisions; lengths in ``l_f``, times in ``tau_K``, signals as in
:mod:`swimrl.physics.body2d`:

* ``signals`` ``(F, K, n, N, 5)``, ``Lambda`` ``(F, K, n, N)`` (the shape factor as the
  environment applies it, :func:`~swimrl.env.actuation.controls`: the action clamped to
  ``[-Lambda_max, Lambda_max]``, or the shape held by ``actuation=steer``); where the action
  steers (:mod:`swimrl.actuation`) also ``direction`` ``(F, K, n, N, d)``, the preferred
  direction ``k_a`` it sets;
* ``position`` ``(F, K, n, N+1, d)``, ``time`` ``(N+1,)``, and the orientation: in 2D
  ``theta`` ``(F, K, n, N+1)``, in 3D ``orientation`` ``(F, K, n, N+1, 3)`` (the unit vector
  ``n``; the signals are then the seven of :mod:`swimrl.physics.body3d`,
  ``signal_names`` says which);
* ``R_hat`` ``(F, K, n)``, ``reference_distance`` ``v_s T``, ``box`` the period ``L`` (NaN for
  an unbounded flow);
* with ``task=target``: ``target`` ``(F, K, n, d)`` (the unwrapped target position ``X``),
  ``arrival_time`` ``(F, K, n)`` (NaN: not arrived), ``arrival_radius``;
* with ``field_every = m > 0``: ``vorticity`` ``(frames, n_g, n_g)``, ``omega tau_K`` of the
  first flow on every ``field_stride``-th grid node (``[y, x]``) at decisions ``0, m, 2m,
  ...`` and at ``T`` (times ``field_time``).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import torch
from tensordict import TensorDictBase

from swimrl.env.actuation import controls
from swimrl.physics.body2d import SIGNAL_NAMES
from swimrl.runs.records import write_npz


class TrajectoryRecorder:
    """Collects every decision of the first ``n`` swimmers of each flow and strategy block."""

    def __init__(self, n: int, field_every: int = 0, field_stride: int = 4):
        self.n = int(n)
        self.field_every, self.field_stride = int(field_every), int(field_stride)
        self._fields: list[np.ndarray] = []
        self._field_time: list[float] = []
        self._chunks: list[dict[str, np.ndarray]] = []
        self._cur: dict[str, list] = {}
        self._env = None
        self.meta: dict = {}

    def start(self, env, block: int, n_blocks: int) -> None:
        """A new flow chunk ``env`` with ``n_blocks`` strategy blocks of ``block`` swimmers."""
        if self.n > block:
            raise ValueError(f"eval.record={self.n} exceeds eval.n_swimmers={block}")
        self._env = env
        self._sel = torch.tensor([k * block + i for k in range(n_blocks) for i in range(self.n)],
                                 device=env.device)
        self._shape = (n_blocks, self.n)
        self._orient = env.body.orientation_name
        self._cur = {"signals": [], "Lambda": [], "position": [], self._orient: []}
        if env.actuation.steers:
            self._cur["direction"] = []
        grid = getattr(env.flow, "grid", None)
        self.meta = {"reference_distance": float(env.reference_distance),
                     "tau_K": float(env.tau_k),
                     "box": float(grid.length) if grid is not None else float("nan"),
                     "signal_names": np.asarray(env.signal_names),
                     "update_interval": float(env.params.update_interval),
                     "shape_factor_max": float(env.params.shape_factor_max)}

    def _field(self, i: int) -> None:
        """Vorticity of the first flow (first chunk only) at decision ``i``."""
        env, k = self._env, self.field_stride
        if self._chunks or not self.field_every or not hasattr(env.flow, "grid_fields"):
            return
        omega = env.flow.grid_fields(torch.zeros(1, dtype=torch.int64), stride=k)[0, ..., 4]
        self._fields.append((omega * env.tau_k).cpu().float().numpy())
        self._field_time.append(i * env.params.update_interval)

    def _state(self) -> None:
        env, sel = self._env, self._sel
        x = (env.start_position() + env.displacement())[:, sel]
        self._cur["position"].append(x.cpu())
        self._cur[self._orient].append(env.orientation[:, sel].cpu())

    def __call__(self, i: int, td: TensorDictBase) -> None:
        """Decision ``i``: signals and action (before the step) and the state."""
        env = self._env
        lam, direction = controls(env.actuation, td.get("action"), env.params.shape_factor_max,
                                  env.batch_size, env.dim, env.pos.dtype)
        self._cur["signals"].append(td.get("signals")[:, self._sel].cpu())
        self._cur["Lambda"].append(lam.view(env.batch_size)[:, self._sel].cpu())
        if direction is not None:
            self._cur["direction"].append(direction[:, self._sel].cpu())
        self._state()
        if self.field_every and i % self.field_every == 0:
            self._field(i)

    def finish(self, r_hat: torch.Tensor) -> None:
        """End of the chunk's episode: final state and the swimmers' ``R_hat`` ``(F, K S)``."""
        self._state()
        self._field(self._env.params.n_decisions)
        f = r_hat.shape[0]
        shape = (f, *self._shape)
        out = {k: torch.stack(v, 2).numpy() for k, v in self._cur.items()}
        chunk = {k: v.reshape(shape + v.shape[2:]) for k, v in out.items()}
        chunk["R_hat"] = r_hat[:, self._sel].cpu().double().numpy().reshape(shape)
        env = self._env
        if env.task.target:
            target = (env.start_position() + env.target)[:, self._sel].cpu().numpy()
            chunk["target"] = target.reshape(shape + (env.dim,))
            arrival = env.outcomes()["arrival_time"][:, self._sel].cpu().double().numpy()
            chunk["arrival_time"] = arrival.reshape(shape)
            self.meta["arrival_radius"] = float(env.arrival_radius)
        self._chunks.append(chunk)
        self._env = None

    def arrays(self) -> dict[str, np.ndarray]:
        """All chunks, concatenated along flows (see the module docstring)."""
        out = {k: np.concatenate([c[k] for c in self._chunks]) for k in self._chunks[0]}
        n_dec = out["Lambda"].shape[-1]
        out["time"] = np.arange(n_dec + 1) * self.meta["update_interval"]
        for k, v in self.meta.items():
            out[k] = np.asarray(v)
        if self._fields:
            out["vorticity"] = np.stack(self._fields)
            out["field_time"] = np.asarray(self._field_time)
        return out


def save_trajectories(arrays: dict[str, np.ndarray], path: Path, strategies: list[str],
                      config: dict) -> Path:
    """Write ``arrays`` (float32 where floating) with the strategy names, the signal names
    and the resolved ``config`` (JSON) to ``path`` (``.npz``, compressed), atomically."""
    data = {k: (v.astype(np.float32) if v.dtype.kind == "f" and v.ndim > 2 and k != "R_hat"
                else v) for k, v in arrays.items()}
    data["strategies"] = np.asarray(strategies)
    if "signal_names" not in data:
        data["signal_names"] = np.asarray(SIGNAL_NAMES)
    data["config"] = np.asarray(json.dumps(config))
    return write_npz(data, path)


def load_trajectories(path: Path) -> dict:
    """A record written by :func:`save_trajectories` (``config`` parsed back to a dict)."""
    with np.load(Path(path)) as z:
        out = {k: z[k] for k in z.files}
    out["config"] = json.loads(str(out["config"]))
    out["strategies"] = [str(s) for s in out["strategies"]]
    out["signal_names"] = [str(s) for s in out["signal_names"]]
    return out
