"""One error type for bad input, and the checks that raise it.

Every check produces one line ``KEY=VALUE is invalid: allowed RANGE`` that names the config
key as the user writes it (``swimmer.shape_factor_max``, ``flow.dns.nu``, ...). The typed
configs (:mod:`swimrl.config` builds them) call these checks in their ``__post_init__``, so a
bad value stops the command before any compute; :func:`keep_number_types` then stores their
numbers as the types the fields declare, so no user of a checked value converts it again.
"""

from __future__ import annotations

import dataclasses
import math
import types
import typing
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager


class ConfigError(ValueError):
    """A config value outside its allowed range (one line naming key, value and range).

    Raised by the constructors of the typed configs (:class:`~swimrl.env.EnvParams`,
    :class:`~swimrl.flows.stochastic.StochasticSpec`, ...) before any compute; the commands print
    it as one line and exit with status 2.
    """


class BadFileError(ValueError):
    """An input file that cannot be read as what it should be (one line naming its path)."""


class NonFiniteError(ArithmeticError):
    """A computed value (loss, parameter, result) that is NaN or infinite: nothing is written."""


class IntegrityError(RuntimeError):
    """Stored data that fails its checksum, or a result that is physically impossible (one
    line naming the file or the quantity and the bound it breaks): nothing is written."""


def fail(key: str, value, allowed: str) -> None:
    """Raise ``ConfigError("KEY=VALUE is invalid: allowed RANGE")``."""
    raise ConfigError(f"{key}={value!r} is invalid: allowed {allowed}")


def require(ok: bool, key: str, value, allowed: str) -> None:
    """:func:`fail` unless ``ok``."""
    if not ok:
        fail(key, value, allowed)


def as_float(key: str, value, ok: Callable[[float], bool], allowed: str) -> float:
    """``value`` as a finite float (not a bool) with ``ok(value)``.

    NaN and infinities are always rejected; their message says that a finite number is
    needed (``allowed a finite number > 0``).
    """
    try:
        f = math.nan if isinstance(value, bool) else float(value)
    except (TypeError, ValueError):
        f = math.nan
    if not math.isfinite(f) and not allowed.startswith(("a ", "an ", "null")):
        allowed = f"a finite number {allowed}"
    require(math.isfinite(f) and ok(f), key, value, allowed)
    return f


def as_int(key: str, value, low: int = 1) -> int:
    """``value`` as an integer ``>= low`` (whole floats such as ``1e6`` are accepted)."""
    return int(as_float(key, value, lambda f: f == int(f) and f >= low, f"an integer >= {low}"))


def one_of(key: str, value, choices: Iterable[str]) -> str:
    """``value`` if it is one of ``choices``."""
    choices = tuple(choices)
    require(value in choices, key, value, f"one of {list(choices)}")
    return str(value)


def as_bool(key: str, value) -> bool:
    """``value`` if it is ``true`` or ``false``."""
    require(isinstance(value, bool), key, value, "true or false")
    return bool(value)


@contextmanager
def key_prefix(prefix: str) -> Iterator[None]:
    """Prefix the key of a :class:`ConfigError` raised inside (``dns.nu`` -> ``flow.dns.nu``)."""
    try:
        yield
    except ConfigError as err:
        raise ConfigError(f"{prefix}{err}") from err


def number_type(hint) -> tuple[type | None, bool]:
    """``(int | float | None, is_tuple)``: the number type a field annotation declares
    (``int``, ``float | None``, ``tuple[int, ...]``); ``None`` for any other annotation."""
    if typing.get_origin(hint) in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(hint) if a is not type(None)]
        hint = args[0] if len(args) == 1 else None
    if typing.get_origin(hint) is tuple:
        args = typing.get_args(hint)
        return (args[0] if args and args[0] in (int, float) else None), True
    return (hint if hint in (int, float) else None), False


def keep_number_types(obj) -> None:
    """After the checks of a frozen dataclass's ``__post_init__``: its int and float fields
    (optional ones, tuples of them) stored as ``int`` and ``float`` (``1e6`` ->
    ``1000000``, ``1`` -> ``1.0``), the types the checks allowed."""
    hints = typing.get_type_hints(type(obj))
    for f in dataclasses.fields(obj):
        kind, is_tuple = number_type(hints[f.name])
        value = getattr(obj, f.name)
        if kind is None or value is None:
            continue
        convert = (lambda v: v if type(v) is int else int(float(v))) if kind is int else float
        object.__setattr__(obj, f.name,
                           tuple(convert(v) for v in value) if is_tuple else convert(value))
