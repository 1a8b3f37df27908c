r"""``swimrl-gain-scan``: R_hat of ``Lambda_max tanh(g mu(s))`` against the gain ``g``.

    swimrl-gain-scan policy=pretrained/ku10 flow.kubo=10 'gains=[1,2,3,5,10]'

A diagnostic of how soft a trained policy's mean is (:mod:`swimrl.analysis.gain_scan`).
"""

from __future__ import annotations

from omegaconf import DictConfig

from swimrl.analysis.gain_scan import gain_scan, markdown
from swimrl.cli import command
from swimrl.config import gain_scan_config


@command("gain_scan", check=lambda cfg, out: gain_scan_config(cfg))
def main(cfg: DictConfig) -> None:
    print(markdown(gain_scan(gain_scan_config(cfg))))


if __name__ == "__main__":
    main()
