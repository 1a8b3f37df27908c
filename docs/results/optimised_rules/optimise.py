"""Optimise the coefficients of the optimised hand-coded rule (``strategy=optimised``,
:mod:`swimrl.policies.optimised`) directly on R_hat, then choose among the best on the
validation flows.

    # search: differential evolution (a whole population per environment), then Nelder-Mead
    python docs/results/optimised_rules/optimise.py search docs/results/optimised_rules/ku10_2d \\
        --dim 2 --kubo 10
    # choose: the best few of the search and the references on the validation seed
    python docs/results/optimised_rules/optimise.py validate docs/results/optimised_rules/ku10_2d

Common random numbers: every candidate is evaluated on the same training flows
(``--seed``, default 3000000, distinct from the validation seed 2000000 and the test seed 0)
from the same starts: the candidates of one batch are blocks of swimmers in one environment
(``ic_blocks``), and a flow chunk depends only on ``(seed, chunk)``
(:func:`swimrl.evaluation.rollout.chunk_seed`, as ``swimrl-compare``), so a candidate's
R_hat does not depend on the batch it was evaluated in and the search is a deterministic
function of its settings. Every evaluation goes to ``DIR/state.json`` (atomically, after
each batch) and is looked up there before any simulation: a search stopped anywhere
(``--max-new``, a kill) resumes by running the same command again, which replays the
deterministic optimisers on the stored evaluations and simulates only what is new.
``validate`` writes ``DIR/validation.json`` and ``DIR/best.json`` (the chosen coefficients).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np
import torch
from hydra import compose, initialize_config_module
from scipy.optimize import differential_evolution, minimize

from swimrl.config import eval_setup
from swimrl.env import build_env
from swimrl.evaluation.rollout import chunk_seed, run_episodes
from swimrl.evaluation.statistics import paired_ratio
from swimrl.physics.body import body
from swimrl.policies.baselines import ShortTimeOptimal
from swimrl.policies.optimised import RULE_COEFFS, check_coefficients, optimised_rule
from swimrl.runs.records import write_json

ROOT = Path(__file__).resolve().parents[3]
#: Search box of (c1, c2, c3, c4, n0, w).
BOUNDS = ((0.0, 10.0), (0.0, 6.0), (-1.0, 2.0), (-1.0, 2.0), (-1.0, 1.0), (0.0, 0.5))
#: The minimal model's fits (eq:fit, docs/results/minimal_fits/) as starting points.
MINIMAL_FITS = ROOT / "docs" / "results" / "minimal_fits"


def log(msg: str) -> None:
    print(f"[{time.strftime('%H:%M:%S')}] {msg}", flush=True)


def setup_for(dim: int, kubo: float, threads: int, kernel: str, overrides: list[str]):
    flow = ["flow=stochastic3d"] if dim == 3 else []
    with initialize_config_module("swimrl.conf", version_base="1.3"):
        cfg = compose("evaluate", overrides=[*flow, f"flow.kubo={kubo}", f"threads={threads}",
                                             f"kernel={kernel}", "eval.progress=false",
                                             *overrides])
    setup = eval_setup(cfg)
    setup.runtime.apply()
    return setup


class Population(torch.nn.Module):
    """Block ``k`` of every flow follows row ``k``: the rule with coefficients ``rows[k]``, or
    STO where the row is ``"sto"``."""

    def __init__(self, rows: list, n_flows: int, n_swimmers: int, dim: int, lam_max: float):
        super().__init__()
        self.names = body(dim).signal_names
        self.sto_rows = [k for k, r in enumerate(rows) if r == "sto"]
        coeffs = [[0.0] * len(RULE_COEFFS) if r == "sto" else list(r) for r in rows]
        self.coeffs = torch.tensor(coeffs, dtype=torch.float64)
        self.f, self.s, self.lam_max = n_flows, n_swimmers, lam_max
        self.sto = ShortTimeOptimal(lam_max)

    def forward(self, td):
        sig = td.get("signals")
        x = sig.reshape(self.f, self.coeffs.shape[0], self.s, sig.shape[-1])
        lam = optimised_rule(x, self.coeffs.to(sig.dtype)[:, None, :], self.lam_max, self.names)
        for k in self.sto_rows:
            lam[:, k] = self.sto(x[:, k]).squeeze(-1)
        td.set("action", lam.reshape(*sig.shape[:-1], 1))
        return td


def simulate(setup, dim: int, rows: list, n_flows: int, n_swimmers: int, seed: int,
             per_chunk: int) -> list[list[float]]:
    """Per-flow mean R_hat of each row on flows ``chunk_seed(seed, c)``, ``per_chunk`` flows
    per chunk (the flows of ``swimrl-compare`` with ``eval.flows_per_batch=per_chunk``)."""
    out: list[list[float]] = [[] for _ in rows]
    lam_max = setup.params.shape_factor_max
    for c, start in enumerate(range(0, n_flows, per_chunk)):
        f = min(per_chunk, n_flows - start)
        env = build_env(setup.flow, setup.params, setup.runtime, f,
                        len(rows) * n_swimmers, chunk_seed(seed, c), ic_blocks=len(rows))
        r = run_episodes(env, Population(rows, f, n_swimmers, dim, lam_max)).double()
        env.check_displacement()
        r = r.reshape(f, len(rows), n_swimmers).mean(-1)
        for k in range(len(rows)):
            out[k] += r[:, k].tolist()
    return out


class BudgetSpentError(Exception):
    """``--max-new`` evaluations simulated in this invocation."""


class Objective:
    """Mean training R_hat of coefficient vectors, from ``state['evaluations']`` where there,
    simulated (in batches, one environment each) and stored otherwise."""

    def __init__(self, args, setup, state: dict, path: Path):
        self.args, self.setup, self.state, self.path = args, setup, state, path
        self.cache = {tuple(e["x"]): e for e in state["evaluations"]}
        self.new = 0
        self.phase = ""

    def save(self) -> None:
        write_json(self.state, self.path)

    def sto(self) -> list[float]:
        if "sto_train" not in self.state:
            a = self.args
            t0 = time.perf_counter()
            (per_flow,) = simulate(self.setup, a.dim, ["sto"], a.flows, a.swimmers, a.seed,
                                   a.flows)
            self.state["sto_train"] = {"per_flow": per_flow, "R_hat": float(np.mean(per_flow)),
                                       "wall_s": time.perf_counter() - t0}
            self.save()
            log(f"STO on the training flows: R_hat = {np.mean(per_flow):.4f} "
                f"({time.perf_counter() - t0:.0f} s)")
        return self.state["sto_train"]["per_flow"]

    def batch(self, xs: list[tuple[float, ...]]) -> list[float]:
        todo = [x for x in dict.fromkeys(xs) if x not in self.cache]
        a = self.args
        for i in range(0, len(todo), a.max_block):
            if a.max_new is not None and self.new >= a.max_new:
                self.save()
                raise BudgetSpentError
            part = todo[i:i + a.max_block]
            t0 = time.perf_counter()
            per_flow = simulate(self.setup, a.dim, part, a.flows, a.swimmers, a.seed, a.flows)
            wall = time.perf_counter() - t0
            for x, pf in zip(part, per_flow, strict=True):
                e = {"i": len(self.state["evaluations"]), "x": list(x), "phase": self.phase,
                     "R_hat": float(np.mean(pf)), "per_flow": pf, "batch_wall_s": wall,
                     "batch_size": len(part)}
                self.state["evaluations"].append(e)
                self.cache[x] = e
            self.new += len(part)
            best = max(self.state["evaluations"], key=lambda e: e["R_hat"])
            sto = self.state["sto_train"]["R_hat"]
            log(f"{self.phase}: {len(part)} new in {wall:.0f} s "
                f"({wall / len(part):.1f} s each); {len(self.state['evaluations'])} evaluated, "
                f"best R_hat {best['R_hat']:.4f} = {best['R_hat'] / sto:.3f} x STO at "
                f"{fmt(best['x'])}")
            self.save()
        return [self.cache[x]["R_hat"] for x in xs]

    def __call__(self, x: np.ndarray) -> np.ndarray | float:
        """Minus the mean R_hat: of one vector ``(6,)``, or of a population ``(6, S)``."""
        if x.ndim == 1:
            return -self.batch([tuple(float(v) for v in x)])[0]
        return -np.asarray(self.batch([tuple(float(v) for v in col) for col in x.T]))


def fmt(x) -> str:
    return "(" + ", ".join(f"{k}={v:.3g}" for k, v in zip(RULE_COEFFS, x, strict=True)) + ")"


def initial_point(args) -> tuple[float, ...]:
    if args.x0:
        return check_coefficients([float(v) for v in args.x0.split(",")], "--x0")
    ku = f"ku{args.kubo:g}"
    fit = json.loads((MINIMAL_FITS / ku / "fit.json").read_text())["coefficients"]
    return (*(float(fit[k]) for k in ("c1", "c2", "c3", "c4")), 0.0, 0.0)


SETTINGS = ("dim", "kubo", "flows", "swimmers", "seed", "kernel", "popsize", "generations",
            "nm_evals", "de_seed", "x0", "override")


def load_state(path: Path, settings: dict) -> dict:
    if path.exists():
        state = json.loads(path.read_text())
        if state["settings"] != settings:
            diff = {k: (state["settings"].get(k), v) for k, v in settings.items()
                    if state["settings"].get(k) != v}
            sys.exit(f"{path} was made with other settings {diff}: use another DIR")
        log(f"resuming {path}: {len(state['evaluations'])} evaluations stored")
        return state
    return {"settings": settings, "evaluations": [], "phases": {}}


def search(args) -> None:
    out = Path(args.dir)
    out.mkdir(parents=True, exist_ok=True)
    x0 = initial_point(args)
    settings = {k: getattr(args, k) for k in SETTINGS}
    settings["x0"] = list(x0)
    settings["bounds"] = [list(b) for b in BOUNDS]
    state = load_state(out / "state.json", settings)
    state["command"] = "python " + " ".join(sys.argv)
    state["threads"] = args.threads
    setup = setup_for(args.dim, args.kubo, args.threads, args.kernel, args.override)
    obj = Objective(args, setup, state, out / "state.json")
    log(f"{args.dim}D Ku = {args.kubo:g}: training flows seed {args.seed}, {args.flows} flows x "
        f"{args.swimmers} swimmers; x0 = {fmt(x0)}")
    try:
        obj.sto()
        obj.phase = "x0"
        obj.batch([x0])
        obj.phase = "de"
        n = len(BOUNDS)
        de = differential_evolution(
            obj, BOUNDS, x0=np.asarray(x0), popsize=args.popsize, maxiter=args.generations,
            init="latinhypercube", seed=args.de_seed, tol=0.0, atol=0.0, polish=False,
            updating="deferred", vectorized=True)
        state["phases"]["de"] = {"x": [float(v) for v in de.x], "R_hat": float(-de.fun),
                                 "nfev": int(de.nfev), "nit": int(de.nit),
                                 "population": n * args.popsize, "message": str(de.message)}
        obj.save()
        log(f"DE done: R_hat {-de.fun:.4f} at {fmt(de.x)} ({de.nfev} evaluations)")
        if args.nm_evals > 0:
            obj.phase = "nelder-mead"
            lo, hi = np.array(BOUNDS).T
            start = np.asarray(de.x)
            simplex = [start] + [np.clip(start + np.eye(n)[i] * 0.1 * (hi - lo)[i]
                                         * (1 if start[i] + 0.1 * (hi - lo)[i] <= hi[i] else -1),
                                         lo, hi) for i in range(n)]
            nm = minimize(obj, start, method="Nelder-Mead", bounds=BOUNDS,
                          options={"maxfev": args.nm_evals, "initial_simplex": np.array(simplex),
                                   "xatol": 1e-3, "fatol": 1e-4})
            state["phases"]["nelder-mead"] = {"x": [float(v) for v in nm.x],
                                              "R_hat": float(-nm.fun), "nfev": int(nm.nfev),
                                              "message": str(nm.message)}
            obj.save()
            log(f"Nelder-Mead done: R_hat {-nm.fun:.4f} at {fmt(nm.x)} ({nm.nfev} evaluations)")
        state["done"] = True
        obj.save()
    except BudgetSpentError:
        log(f"--max-new {args.max_new} reached: stopped, {out / 'state.json'} saved; run the "
            "same command again to go on")


def distinct_best(evals: list[dict], k: int) -> list[dict]:
    """The ``k`` best evaluations whose coefficients differ (by 2 % of the box) from every
    better one's."""
    lo, hi = np.array(BOUNDS).T
    chosen: list[dict] = []
    for e in sorted(evals, key=lambda e: -e["R_hat"]):
        x = (np.array(e["x"]) - lo) / (hi - lo)
        if all(np.abs(x - (np.array(c["x"]) - lo) / (hi - lo)).max() > 0.02 for c in chosen):
            chosen.append(e)
        if len(chosen) == k:
            break
    return chosen


def validate(args) -> None:
    out = Path(args.dir)
    state = json.loads((out / "state.json").read_text())
    s = state["settings"]
    setup = setup_for(s["dim"], s["kubo"], args.threads, s["kernel"], s["override"])
    cands = distinct_best(state["evaluations"], args.top)
    x0 = tuple(s["x0"])
    rows = ["sto", x0] + [tuple(c["x"]) for c in cands]
    labels = ["sto", "x0 (the search's start)"] + [f"train #{c['i']}" for c in cands]
    log(f"validating {len(cands)} candidates + STO + x0 on seed {args.seed}: {args.flows} "
        f"flows x {args.swimmers} swimmers")
    t0 = time.perf_counter()
    per_flow = simulate(setup, s["dim"], rows, args.flows, args.swimmers, args.seed,
                        args.flows_per_batch)
    wall = time.perf_counter() - t0
    sto = np.array(per_flow[0])
    table = []
    for label, row, pf in zip(labels, rows, per_flow, strict=True):
        a = np.array(pf)
        r, sem = paired_ratio(a, sto)
        train = next((e["R_hat"] for e in state["evaluations"] if tuple(e["x"]) == row), None)
        table.append({"label": label, "x": None if row == "sto" else list(row),
                      "R_hat": float(a.mean()),
                      "R_hat_sem": float(a.std(ddof=1) / math.sqrt(a.size)),
                      "ratio_to_sto": r, "ratio_sem": sem, "per_flow": pf,
                      "train_R_hat": train if row != "sto" else state["sto_train"]["R_hat"]})
        log(f"{label:28s} R_hat {a.mean():.4f}  {r:.3f} +- {sem:.3f} x STO")
    rec = {"seed": args.seed, "n_flows": args.flows, "n_swimmers": args.swimmers,
           "flows_per_batch": args.flows_per_batch, "wall_s": wall, "threads": args.threads,
           "command": "python " + " ".join(sys.argv), "rows": table}
    write_json(rec, out / "validation.json")
    best = max(table[1:], key=lambda t: t["R_hat"])
    write_json({"coefficients": dict(zip(RULE_COEFFS, best["x"], strict=True)),
                "signals": list(body(s["dim"]).signal_names), "dim": s["dim"], "kubo": s["kubo"],
                "chosen_on": f"validation seed {args.seed}, {args.flows} x {args.swimmers}",
                "validation_ratio_to_sto": [best["ratio_to_sto"], best["ratio_sem"]],
                "train_R_hat": best["train_R_hat"], "label": best["label"]},
               out / "best.json")
    log(f"chosen: {best['label']} {fmt(best['x'])}: {best['ratio_to_sto']:.3f} +- "
        f"{best['ratio_sem']:.3f} x STO on the validation flows ({wall:.0f} s)")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    s = sub.add_parser("search", help="DE then Nelder-Mead on the training flows")
    s.add_argument("dir")
    s.add_argument("--dim", type=int, choices=(2, 3), required=True)
    s.add_argument("--kubo", type=float, required=True)
    s.add_argument("--flows", type=int, default=8)
    s.add_argument("--swimmers", type=int, default=100)
    s.add_argument("--seed", type=int, default=3000000, help="training flows")
    s.add_argument("--popsize", type=int, default=3, help="DE population: popsize x 6")
    s.add_argument("--generations", type=int, default=10, help="DE generations after the first")
    s.add_argument("--nm-evals", type=int, default=40, help="Nelder-Mead evaluations")
    s.add_argument("--de-seed", type=int, default=0)
    s.add_argument("--x0", default=None, help="c1,c2,c3,c4,n0,w (default: the minimal fit)")
    s.add_argument("--kernel", default="auto")
    s.add_argument("--override", action="append", default=[], help="a Hydra override")
    s.add_argument("--threads", type=int, default=1)
    s.add_argument("--max-block", type=int, default=24, help="candidates per environment")
    s.add_argument("--max-new", type=int, default=None, help="stop after this many new ones")
    v = sub.add_parser("validate", help="the best few of the search on the validation flows")
    v.add_argument("dir")
    v.add_argument("--top", type=int, default=5)
    v.add_argument("--seed", type=int, default=2000000)
    v.add_argument("--flows", type=int, default=20)
    v.add_argument("--swimmers", type=int, default=200)
    v.add_argument("--flows-per-batch", type=int, default=10)
    v.add_argument("--threads", type=int, default=1)
    args = p.parse_args()
    search(args) if args.cmd == "search" else validate(args)


if __name__ == "__main__":
    main()
