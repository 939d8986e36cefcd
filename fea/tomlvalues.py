"""Typed values of LINK.toml: each read names the file, the section and the
key, and every problem is a :class:`ConfigError` (an InputError)."""

from __future__ import annotations

from collections.abc import Iterable

from ..errors import InputError
from ..io import validate as V


class ConfigError(InputError):
    """LINK.toml is missing, malformed or has an invalid value."""


suggest = V.suggest


def get_value(tbl: dict, key: str, where: str, path: str, kind: type | None = None, default: object = ...) -> object:
    if key not in tbl:
        if default is ...:
            raise ConfigError(f"{path}: [{where}] {key} is missing")
        return default
    v = tbl[key]
    name = f"{path}: [{where}] {key}"
    if kind is float:
        return number(v, name)
    if kind is int:
        if isinstance(v, bool) or not isinstance(v, int):
            raise ConfigError(f"{name} = {v!r} must be an integer")
        return v
    if kind is str:
        if not isinstance(v, str):
            raise ConfigError(f"{name} = {v!r} must be a string")
        return v
    if kind is list:
        if not isinstance(v, list) or not v:
            raise ConfigError(f"{name} = {v!r} must be a list of numbers")
        return [number(x, f"{name}[{i}]") for i, x in enumerate(v)]
    if kind is bool:
        if not isinstance(v, bool):
            raise ConfigError(f"{name} = {v!r}: true or false")
        return v
    return v


def number(v: object, name: str, q: str | None = None, **limits: object) -> float:
    """validate.number raising ConfigError (the LINK.toml reader's class)."""
    try:
        return V.number(v, name, q, **limits)
    except InputError as exc:
        raise ConfigError(str(exc)) from None


def choice(v: object, choices: Iterable[object], where: str, key: str, path: str) -> object:
    if v not in choices:
        raise ConfigError(
            f"{path}: [{where}] {key} = {v!r}{suggest(v, map(str, choices))}: "
            f"choose one of {', '.join(map(str, choices))}"
        )
    return v


def positive(v: float, where: str, key: str, path: str) -> float:
    if not v > 0:
        raise ConfigError(f"{path}: [{where}] {key} = {v!r} must be positive")
    return v
