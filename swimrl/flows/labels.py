r"""Ku labels: the one name of a Kubo number, its parser, and its display in titles.

* :func:`ku_name` (``ku0.1``, ``ku1``, ``ku10``, ``ku1e7``): the one machine label. It names
  the shipped policies (``pretrained/ku1e7``), the run directories of ``swimrl-train``
  (``${flow_tag:${flow}}``: ``..._ku1e7_seed0``), the protocol's runs and records
  (``paper_runs/ku1e7_seed0``, ``paper_protocol/ku1e7``), the figures' evaluations, cache
  files and videos. The number is ``%g`` with the exponent's sign and leading zeros dropped
  (``1e+07`` -> ``1e7``, ``1e-05`` -> ``1e-5``). ``${ku:${flow.kubo}}`` in a config is
  the same label without its ``ku`` (``ku${ku:${flow.kubo}}``: the committed multiruns).
* :func:`parse_ku_name`: the one parser, the number back from a ``ku<number>`` name in any form
  it was ever written (``ku1e7``, ``ku1e+07``, ``ku10000000``, ``ku10000000.0``, ``ku10.0``:
  older run directories and records), ``ku`` in any case.
* :func:`ku_display` (``Ku = 10``, ``Ku = 1e+07``; ``sep="="``: ``Ku=10``): human text for
  titles, tables and progress lines, not a name; :func:`ku_number` is its number (``%g``),
  for a table column already headed ``Ku``.

:func:`ku_name` and :func:`ku_display` also take a flow: a record's flow config
(``{"name": ..., "kubo": ...}``) labelled by its Kubo number when it is the stochastic flow,
else by its name (``dns_replay``), or a flow's name.
"""

from __future__ import annotations

import re
from collections.abc import Mapping

#: A non-negative decimal number, with an optional exponent (``10``, ``0.1``, ``.5``, ``1e+07``).
NUMBER = r"(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?"
_NAME = re.compile(rf"ku({NUMBER})", re.IGNORECASE)


def _kubo_or_name(flow: Mapping | float | str) -> float | str:
    """The Kubo number of a stochastic flow's config (or a number), else the flow's name."""
    if isinstance(flow, Mapping):
        return float(flow["kubo"]) if flow["name"] == "stochastic" else str(flow["name"])
    return str(flow) if isinstance(flow, str) else float(flow)


def ku_name(flow: Mapping | float | str) -> str:
    """``ku0.1``, ``ku1``, ``ku10``, ``ku1e7``: the one machine label of a Kubo number (or of
    a stochastic flow's config; another flow's config with a ``kubo`` gives
    ``<name>_ku<Ku>``, ``stochastic3d_ku10``; one without, or a name, gives the name)."""
    if isinstance(flow, Mapping) and flow["name"] != "stochastic" and "kubo" in flow:
        return f"{flow['name']}_{ku_name(float(flow['kubo']))}"
    kubo = _kubo_or_name(flow)
    if isinstance(kubo, str):
        return kubo
    mantissa, _, exponent = ku_number(kubo).partition("e")
    return "ku" + mantissa + (f"e{int(exponent)}" if exponent else "")


def parse_ku_name(text: str) -> float | None:
    """The Kubo number of a ``ku<number>`` name: :func:`ku_name`'s and the older forms
    (``ku1e7``, ``ku1e+07``, ``ku10000000``, ``ku10.0``; ``ku`` in any case); None for
    anything else (``ku10_seed0``, ``dns``, ``10``, ``Ku = 10``)."""
    m = _NAME.fullmatch(str(text))
    return float(m.group(1)) if m else None


def ku_number(kubo: float) -> str:
    """``0.1``, ``10``, ``1e+07``: the Kubo number as ``%g``, the number of :func:`ku_display`."""
    return f"{float(kubo):g}"


def ku_display(flow: Mapping | float | str, sep: str = " = ") -> str:
    """``Ku = 10``, ``Ku = 1e+07`` (``sep="="``: ``Ku=10``): the Kubo number in a title (of a
    number or a stochastic flow's config; another flow's config or name gives the name)."""
    kubo = _kubo_or_name(flow)
    return kubo if isinstance(kubo, str) else f"Ku{sep}{ku_number(kubo)}"
