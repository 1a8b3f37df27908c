"""Reproduction row 4: the optimal-control baseline of Sec. III A and App. D, measured.

The paper: Pontryagin's principle applied to the cost -|x(T) - x(0)|^2 gives a constant
Lambda = -1, whose angular dynamics are Zermelo's minimum-time heading equation, so that
"provided the initial orientation is appropriately chosen, swimmers with Lambda = -1 reach any
admissible target point, including the point farthest from the origin, faster than
microswimmers with other values of Lambda. However, in turbulent flows, trajectories with
Lambda = -1 are extremely sensitive to initial conditions and most become trapped in
high-vorticity regions" (the reason the paper takes Lambda = 0.98 as its naive baseline).
(The identity of the Lambda = -1 rate with Zermelo's is a unit test:
``tests/test_swimmer.py::test_lambda_minus_one_turns_as_zermelo_heading``.)

Measured here, for constant shapes Lambda in LAMBDAS on the same flows from the same starts:

* the best initial orientation: from each of ``starts`` start points per flow, ``orientations``
  initial angles on a uniform grid; per start and Lambda the largest R_hat(t) = |x(t) - x(0)|
  / (v_s t) over the angles (the best-chosen orientation), its mean over starts, at times
  TIMES (in tau_K), and its difference from Lambda = LAMBDAS[-1]'s paired over the starts;
* sensitivity to the initial orientation: the mean |R_hat(theta_k+1) - R_hat(theta_k)| between
  neighbouring angles (1 degree apart at 360), over the mean R_hat, at each time;
* trapping in high-vorticity regions: the fraction of decisions at which the swimmer is in a
  vorticity-dominated region, omega^2 / 4 > S_nn^2 + S_np^2 (the Okubo-Weiss criterion: the
  local rotation rate exceeds the strain rate; both sides are frame-invariant), over the run,
  against the same fraction at uniformly placed points (the Eulerian value, the t = 0 signals);
  and the mean omega^2 and strain rate^2 = S_nn^2 + S_np^2 along the paths over their Eulerian
  means (> 1: the swimmers sample high-vorticity / high-strain regions preferentially);
* confinement: the fraction of swimmers with R_hat < CONFINED at the last time (for a swimmer
  that keeps a direction R_hat stays O(1); one that circles in a region falls as 1/t).

Writes one JSON (and the figure ``optimal_escape.png`` beside it).
Usage:  python optimal_escape.py OUT.json [--kubo 1e7 10] [--flows 4] [--starts 8]
        [--orientations 360] [--duration 50] [--seed 0] [--threads 1]
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np
import torch

from swimrl import EnvParams, Runtime, StochasticSpec, build_env
from swimrl.flows.labels import ku_name

LAMBDAS = (-0.98, -0.5, 0.0, 0.5, 0.98)
TIMES = (1, 2, 5, 10, 20, 50, 100, 200)
CONFINED = 0.1


def vortex_dominated(signals: torch.Tensor) -> torch.Tensor:
    """``omega^2 / 4 > S_nn^2 + S_np^2`` (signals ``n_r, n_theta, S_nn, S_np, omega``)."""
    return signals[..., 4] ** 2 / 4 > signals[..., 2] ** 2 + signals[..., 3] ** 2


def run(kubo: float, flows: int, starts: int, orientations: int, duration: float, seed: int,
        threads: int) -> dict:
    """One Kubo number: every Lambda of LAMBDAS from the same starts and angles."""
    params = EnvParams(duration=duration)
    n_lam = len(LAMBDAS)
    per_flow = n_lam * starts * orientations
    env = build_env(StochasticSpec(kubo=kubo), params,
                    Runtime.from_names("cpu", "float32", threads), flows, per_flow,
                    seed=seed)
    td = env.reset()
    sig0 = env.signals()
    eulerian = float(vortex_dominated(sig0).float().mean())
    omega2_e = float((sig0[..., 4] ** 2).mean())
    strain2_e = float((sig0[..., 2] ** 2 + sig0[..., 3] ** 2).mean())
    # swimmer index within a flow = (lambda, start, angle)
    pos = env.pos.view(flows, n_lam, starts, orientations, 2)
    pos[:] = pos[:, :1, :, :1, :].clone()            # each start's position for every angle
    env.start_pos.copy_(env.pos)
    theta = torch.arange(orientations, dtype=env.pos.dtype) * (2 * math.pi / orientations)
    env.theta.view(flows, n_lam, starts, orientations)[:] = theta
    lam = torch.tensor(LAMBDAS, dtype=env.pos.dtype).view(1, n_lam, 1, 1)
    action = lam.expand(flows, n_lam, starts, orientations).reshape(flows, per_flow, 1)
    # td (the reset's observation) only carries the constant action from here on
    times = [t for t in TIMES if t <= duration]
    steps = {int(round(t / params.update_interval)): t for t in times}
    trapped = torch.zeros(flows, n_lam, starts, orientations)
    omega2 = torch.zeros(flows, n_lam, starts, orientations)
    strain2 = torch.zeros(flows, n_lam, starts, orientations)
    out: dict = {"best": {}, "mean": {}, "roughness": {}, "best_minus_prolate": {}}
    for i in range(1, params.n_decisions + 1):
        td.set("action", action.clone())
        td = env.step(td)["next"]
        sig = env.signals().view(*trapped.shape, -1).float()
        trapped += vortex_dominated(sig).float()
        omega2 += sig[..., 4] ** 2
        strain2 += sig[..., 2] ** 2 + sig[..., 3] ** 2
        if i in steps:
            t = steps[i]
            r = (env.displacement().norm(dim=-1) / (env.swim_speed * t * env.flow.tau_k))
            r = r.view(flows, n_lam, starts, orientations).double()
            last = r
            best = r.amax(dim=-1)                                  # (F, L, S)
            rough = (r - r.roll(1, dims=-1)).abs().mean(dim=-1) / r.mean(dim=-1)
            diff = best - best[:, -1:]              # paired over starts: minus Lambda = 0.98
            for j, lam_j in enumerate(LAMBDAS):
                key = f"{lam_j:+.2f}"
                for name, val in (("best", best), ("mean", r.mean(dim=-1)),
                                  ("roughness", rough), ("best_minus_prolate", diff)):
                    v = val[:, j].reshape(-1).numpy()
                    out[name].setdefault(key, {})[f"{t:g}"] = {
                        "mean": float(v.mean()),
                        "sem": float(v.std(ddof=1) / math.sqrt(v.size)) if v.size > 1 else 0.0}
    frac = (trapped / params.n_decisions).mean(dim=(2, 3))         # (F, L)
    out["vortex_fraction"] = {
        f"{lam_j:+.2f}": {"mean": float(frac[:, j].mean()),
                          "sem": float(frac[:, j].std() / math.sqrt(flows)) if flows > 1 else 0.0}
        for j, lam_j in enumerate(LAMBDAS)}
    out["vortex_fraction_eulerian"] = eulerian
    for name, acc, ref in (("omega2_ratio", omega2, omega2_e),
                           ("strain2_ratio", strain2, strain2_e)):
        v = (acc / params.n_decisions).mean(dim=(2, 3)) / ref                # (F, L)
        out[name] = {f"{lam_j:+.2f}": {"mean": float(v[:, j].mean()),
                                       "sem": float(v[:, j].std() / math.sqrt(flows))
                                       if flows > 1 else 0.0}
                     for j, lam_j in enumerate(LAMBDAS)}
    conf = (last < CONFINED).double().mean(dim=(2, 3))                       # (F, L)
    out["confined_fraction"] = {f"{lam_j:+.2f}": float(conf[:, j].mean())
                                for j, lam_j in enumerate(LAMBDAS)}
    out["confined_at"] = {"time": times[-1], "R_hat_below": CONFINED}
    # the best constant shape at each time: which Lambda has the largest best-orientation R_hat
    out["best_shape"] = {f"{t:g}": max(out["best"],
                                       key=lambda k, t=t: out["best"][k][f"{t:g}"]["mean"])
                         for t in times}
    env.check_displacement()
    return out


def figure(result: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    kus = list(result["by_ku"])
    fig, axes = plt.subplots(len(kus), 4, figsize=(17, 3.6 * len(kus)), squeeze=False)
    colors = plt.get_cmap("coolwarm")
    for row, ku in zip(axes, kus, strict=True):
        res = result["by_ku"][ku]
        for k, key in enumerate(res["best"]):
            c = colors(k / max(1, len(res["best"]) - 1))
            t = np.array([float(x) for x in res["best"][key]])
            for ax, name, ls in ((row[0], "best", "-"), (row[0], "mean", ":"),
                                 (row[1], "roughness", "-")):
                m = np.array([res[name][key][x]["mean"] for x in res[name][key]])
                e = np.array([res[name][key][x]["sem"] for x in res[name][key]])
                ax.errorbar(t, m, yerr=e, color=c, ls=ls, marker="o", ms=3, capsize=2,
                            label=f"$\\Lambda$ = {float(key):g}" if name != "mean" else None)
            v = res["vortex_fraction"][key]
            row[2].bar(k, v["mean"], yerr=v["sem"], color=c)
            for off, name, hatch in ((-0.2, "omega2_ratio", None), (0.2, "strain2_ratio", "//")):
                v = res[name][key]
                row[3].bar(k + off, v["mean"], yerr=v["sem"], width=0.4, color=c, hatch=hatch,
                           edgecolor="k", lw=0.5)
        row[2].axhline(res["vortex_fraction_eulerian"], color="k", ls="--", lw=1,
                       label="uniform points")
        row[2].set_xticks(range(len(res["best"])), [f"{float(k):g}" for k in res["best"]])
        row[2].set_xlabel(r"$\Lambda$")
        row[2].set_ylabel("fraction of time with $\\omega^2/4 > S_{nn}^2 + S_{np}^2$")
        row[2].legend(fontsize=7)
        for ax in row[:2]:
            ax.set_xscale("log")
            ax.set_xlabel(r"$t/\tau_K$")
            ax.legend(fontsize=7)
        row[0].set_ylabel(r"$\hat R(t)$")
        row[1].set_ylabel(r"$\langle|\hat R(\theta_{k+1}) - \hat R(\theta_k)|\rangle"
                          r" / \langle\hat R\rangle$")
        row[0].set_title(f"{ku}: best initial orientation (—), mean over orientations (···)",
                         fontsize=9)
        row[1].set_title("sensitivity to the initial orientation", fontsize=9)
        row[2].set_title("time in vorticity-dominated regions", fontsize=9)
        row[3].axhline(1, color="k", ls="--", lw=1)
        row[3].set_xticks(range(len(res["best"])), [f"{float(k):g}" for k in res["best"]])
        row[3].set_xlabel(r"$\Lambda$")
        row[3].set_ylabel("along the paths / at uniform points")
        row[3].set_title(r"$\langle\omega^2\rangle$ (plain), $\langle S_{nn}^2 + S_{np}^2\rangle$"
                         " (hatched)", fontsize=9)
    s = result["sizes"]
    fig.suptitle(f"Constant shapes from the same starts: {s['flows']} flows x {s['starts']} "
                 f"starts x {s['orientations']} orientations per shape, test seed {s['seed']}",
                 fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    p.add_argument("out", type=Path)
    p.add_argument("--kubo", type=float, nargs="+", default=[1e7, 10.0])
    p.add_argument("--flows", type=int, default=4)
    p.add_argument("--starts", type=int, default=8)
    p.add_argument("--orientations", type=int, default=360)
    p.add_argument("--duration", type=float, default=50.0)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--threads", type=int, default=1)
    a = p.parse_args(argv)
    sizes = {"flows": a.flows, "starts": a.starts, "orientations": a.orientations,
             "duration": a.duration, "seed": a.seed, "lambdas": list(LAMBDAS)}
    result = {"sizes": sizes, "by_ku": {ku_name(k): run(k, a.flows, a.starts, a.orientations,
                                                      a.duration, a.seed, a.threads)
                                        for k in a.kubo}}
    a.out.write_text(json.dumps(result, indent=1) + "\n")
    figure(result, a.out.with_suffix(".png"))


if __name__ == "__main__":
    main()
