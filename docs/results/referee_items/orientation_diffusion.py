"""Referee item 4: the small-Ku orientation diffusion (Delta theta)^2 ~ 2 omega_rms^2 tau_f tau.

The paper (Sec. "Smart strategy in rapidly fluctuating flows"): "The orientation change over a
time interval tau due to vorticity is Delta theta = int_0^tau omega dt. In the limit
tau >> tau_f, this yields the diffusive scaling (Delta theta)^2 ~ 2 omega_rms^2 tau_f tau."

Reads trajectories.npz records written by ``swimrl-eval ... eval.record=N`` (every decision of
N swimmers per flow: signals incl. omega*tau_K and S_np*tau_K, the action Lambda, the angle
theta at t_i = i T_u) and writes one JSON with, per record and lag tau:

* ``msd_int_omega``: <(int_t^{t+tau} omega dt')^2>, omega integrated along the recorded
  trajectory (left Riemann sum over the decisions, step T_u): the paper's Delta theta as
  written;
* ``msd_theta``: <(theta(t+tau) - theta(t))^2> of the swimmer's own (unwrapped) angle, whose
  rate in the model is theta_dot = omega/2 + Lambda S_np (the paper's eq. thetaDot);
* the paper's prediction ``2 <omega^2> tau_f tau`` and the same form with the model's
  rotation rate, ``2 <theta_dot^2> tau_f tau`` (theta_dot from the recorded signals);
* the ratios measured / predicted, with the SEM over flows (each flow's swimmers averaged
  first; flows are independent), and the log-log slope of each MSD between lags.

Averages run over flows, recorded swimmers and all start times t (the flow is stationary and
a naive swimmer's statistics do not depend on t). Units: times in tau_K; with the stochastic
flow's tau_K = ell_f/(2 u_rms) (docs/physics.md), tau_f = Ku ell_f/u_rms = 2 Ku tau_K.

Usage:  python orientation_diffusion.py OUT.json LABEL=RUN_DIR_OR_NPZ [LABEL=...]
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

LAGS_TAU_K = [0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0]


def _msd_per_flow(x: np.ndarray, lag: int) -> np.ndarray:
    """<(x[t+lag] - x[t])^2> over swimmers and t, per flow; x is (F, n, T)."""
    d = x[..., lag:] - x[..., :-lag]
    return (d * d).mean(axis=(1, 2))


def _mean_sem(v: np.ndarray) -> tuple[float, float]:
    return float(v.mean()), float(v.std(ddof=1) / np.sqrt(len(v)))


def analyse(path: Path) -> dict:
    z = np.load(path)
    cfg = json.loads(str(z["config"]))
    names = [str(s) for s in z["signal_names"]]
    dt = float(z["update_interval"])  # T_u / tau_K
    tau_k = float(z["tau_K"])  # in ell_f / u_rms
    ku = float(cfg["flow"]["kubo"])
    tau_f = ku / tau_k  # tau_f = Ku ell_f/u_rms, in tau_K
    sig = z["signals"][:, 0].astype(np.float64)  # (F, n, N, 5)
    lam = z["Lambda"][:, 0].astype(np.float64)  # (F, n, N)
    theta = np.unwrap(z["theta"][:, 0].astype(np.float64), axis=-1)  # (F, n, N+1)
    omega = sig[..., names.index("omega")]  # omega * tau_K
    s_np = sig[..., names.index("S_np")]
    rate = 0.5 * omega + lam * s_np  # theta_dot * tau_K (eq. thetaDot)
    # check of the rate's sign convention: the one-step increment of theta against rate*T_u
    dtheta = np.diff(theta, axis=-1)
    corr = float(np.corrcoef(dtheta.ravel(), rate.ravel())[0, 1])
    int_omega = np.concatenate([np.zeros(omega.shape[:-1] + (1,)),
                                np.cumsum(omega, axis=-1) * dt], axis=-1)  # (F, n, N+1)
    w2_f = (omega ** 2).mean(axis=(1, 2))
    r2_f = (rate ** 2).mean(axis=(1, 2))
    n_dec = omega.shape[-1]

    # Lagrangian correlation times: integral of the normalised autocorrelation (trapezoid
    # over the decision spacing T_u, up to 10 tau_f or 5 tau_K, whichever is longer)
    def corr_time(x: np.ndarray) -> float:
        xc = x - x.mean()
        var = (xc * xc).mean()
        smax = min(n_dec - 1, int(round(max(10 * tau_f, 5.0) / dt)))
        c = [1.0] + [float((xc[..., s:] * xc[..., :-s]).mean() / var) for s in range(1, smax + 1)]
        return float(np.trapezoid(c, dx=dt) if hasattr(np, "trapezoid") else np.trapz(c, dx=dt))

    rows = []
    for tau in LAGS_TAU_K:
        lag = int(round(tau / dt))
        if lag >= n_dec:
            continue
        m_w = _msd_per_flow(int_omega, lag)
        m_t = _msd_per_flow(theta, lag)
        pred_w = 2 * w2_f * tau_f * tau  # paper: 2 <omega^2> tau_f tau (per flow's <omega^2>)
        pred_r = 2 * r2_f * tau_f * tau  # same form with theta_dot
        rows.append({
            "tau_over_tau_K": tau, "tau_over_tau_f": tau / tau_f,
            "msd_int_omega": _mean_sem(m_w), "msd_theta": _mean_sem(m_t),
            "paper_2_omega2_tauf_tau": _mean_sem(pred_w),
            "model_2_thetadot2_tauf_tau": _mean_sem(pred_r),
            "ratio_int_omega_to_paper": _mean_sem(m_w / pred_w),
            "ratio_theta_to_paper": _mean_sem(m_t / pred_w),
            "ratio_theta_to_model_rate": _mean_sem(m_t / pred_r),
        })
    for a, b in zip(rows[:-1], rows[1:], strict=True):
        for key in ("msd_int_omega", "msd_theta"):
            a[f"slope_{key}_to_next"] = float(np.log(b[key][0] / a[key][0])
                                              / np.log(b["tau_over_tau_K"] / a["tau_over_tau_K"]))
    return {
        "file": str(path), "strategy": str(z["strategies"][0]), "Ku": ku,
        "tau_K_code_units": tau_k, "tau_f_over_tau_K": tau_f, "T_u_over_tau_K": dt,
        "flows": int(omega.shape[0]), "swimmers_per_flow": int(omega.shape[1]),
        "decisions": n_dec, "seed": cfg.get("seed"),
        "Lambda_mean": float(lam.mean()),
        "omega2_tauK2": _mean_sem(w2_f), "thetadot2_tauK2": _mean_sem(r2_f),
        "corr_dtheta_step_vs_rate": corr,
        "corr_time_omega_over_tau_K": corr_time(omega),
        "corr_time_thetadot_over_tau_K": corr_time(rate),
        "R_hat_recorded_mean": float(z["R_hat"].mean()),
        "lags": rows,
    }


def main(argv: list[str]) -> None:
    out = Path(argv[0])
    result = {"what": __doc__.split("\n\n")[0], "units": "times in tau_K; tau_f = 2 Ku tau_K",
              "records": {}}
    for arg in argv[1:]:
        label, p = arg.split("=", 1)
        p = Path(p)
        result["records"][label] = analyse(p / "trajectories.npz" if p.is_dir() else p)
    out.write_text(json.dumps(result, indent=1) + "\n")
    print(f"wrote {out}")


if __name__ == "__main__":
    main(sys.argv[1:])
