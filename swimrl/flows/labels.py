r"""Ku labels: the one format of the Kubo number in names and titles, and its parser.

Every label writes the number with ``%g`` (:func:`ku_number`: ``0.1``, ``10``, ``1e+07``):

* :func:`kubo_label` (``0.1``, ``1``, ``10``, ``1e7``: ``%g`` without the exponent's ``+0``),
  the ``${ku:...}`` resolver of the configs; :func:`ku_name` (``ku1e7``) names the shipped
  policies (``pretrained/ku1e7``), the figures' cached records and their videos;
* :func:`ku_display` (``Ku = 1e+07``, or ``Ku=10``) and :func:`flow_display` (that, or a
  flow's name) in titles, tables and summary lines;
* :func:`flow_tag` (``ku10.0``: the number as the config holds it) in the run-directory
  names of ``swimrl-train`` (``${flow_tag:${flow}}``).

:func:`parse_kubo` reads any of them back (``ku1e7``, ``ku1e+07``, ``1e+07``, ``10000000``,
``ku10.0``, ``Ku = 10`` -> the number); :func:`parse_ku_name` only the ``ku<number>`` names.
"""

from __future__ import annotations

import re
from collections.abc import Mapping

#: A non-negative decimal number, with an optional exponent (``10``, ``0.1``, ``.5``, ``1e+07``).
NUMBER = r"(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?"
_NAME = re.compile(rf"ku({NUMBER})", re.IGNORECASE)
_LABEL = re.compile(rf"(?:ku\s*(?:=\s*)?)?({NUMBER})", re.IGNORECASE)


def ku_number(kubo: float) -> str:
    """``0.1``, ``10``, ``1e+07``: the Kubo number as ``%g``."""
    return f"{float(kubo):g}"


def kubo_label(kubo: float) -> str:
    """``0.1``, ``1``, ``10``, ``1e7``: the Kubo number as the shipped policies and records
    name it (:func:`ku_number` without the exponent's ``+0``)."""
    return ku_number(kubo).replace("e+0", "e").replace("e+", "e")


def ku_name(kubo: float) -> str:
    """``ku0.1``, ``ku1``, ``ku10``, ``ku1e7``: the shipped policies' names."""
    return "ku" + kubo_label(kubo)


def ku_display(kubo: float, sep: str = " = ") -> str:
    """``Ku = 10``, ``Ku = 1e+07`` (``sep="="``: ``Ku=10``): the Kubo number in a title."""
    return f"Ku{sep}{ku_number(kubo)}"


def flow_display(flow: Mapping | float | str, sep: str = " = ") -> str:
    """:func:`ku_display` of a stochastic flow, else the flow's name; ``flow`` is a record's
    flow config (``{"name": ..., "kubo": ...}``), a Kubo number or a flow's name."""
    if isinstance(flow, Mapping):
        flow = flow["kubo"] if flow["name"] == "stochastic" else flow["name"]
    return flow if isinstance(flow, str) else ku_display(flow, sep)


def flow_tag(name: str, kubo=None) -> str:
    """Run-directory tag of a flow: ``ku10.0`` for the stochastic flow (``ku`` and the number
    as the config holds it: ``10.0``, ``10``, ``10000000.0``), else the flow's name."""
    return f"ku{kubo}" if name == "stochastic" else str(name)


def parse_kubo(text: str) -> float | None:
    """The Kubo number of any label above: ``ku1e7``, ``ku1e+07``, ``1e+07``, ``10000000``,
    ``ku10.0``, ``Ku = 10`` (``ku`` in any case); None for anything else."""
    m = _LABEL.fullmatch(str(text).strip())
    return float(m.group(1)) if m else None


def parse_ku_name(text: str) -> float | None:
    """The Kubo number of a ``ku<number>`` name (:func:`ku_name`, :func:`flow_tag`: ``ku1e7``,
    ``ku1e+07``, ``ku10000000``, ``ku10.0``; ``ku`` in any case); None for anything else
    (``ku10_seed0``, ``dns``, ``10``)."""
    m = _NAME.fullmatch(str(text))
    return float(m.group(1)) if m else None
