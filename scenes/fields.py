"""Scene fields: how a field is declared (:func:`spec`: its default, check, unit, meaning and
bounds), the checks of its value (a :class:`Check` returns the value as the scene keeps it or
raises :class:`SceneError` naming the field), and :class:`Section`, the base of the scene's
sections, which runs every field's check and reads and writes a section as a table."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import field
from typing import Any, Callable

from .errors import SceneError

PRESTRETCH_MAX = 10.0
"""Largest pre-stretch ratio a scene may ask for (elastomer films tear well below 10)."""

MAX_VERTICES = 256
"""Most corners of a polygon outline (the outline checks are O(k^2))."""

MAX_SWEEP = 1000
"""Most pre-stretch levels in a sweep."""


def _number(name: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise SceneError(f"{name} = {show_value(value)} must be a finite number")
    try:
        v = float(value)
    except OverflowError:
        v = math.inf
    if not math.isfinite(v):
        raise SceneError(f"{name} = {show_value(value)} must be a finite number")
    return v


def show_value(value: Any) -> str:
    """A field's value for a message, cut short if long."""
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


class Check:
    """A field's check: ``check(name, value)`` returns the value as the scene keeps it or raises
    :class:`SceneError` naming the field; ``bounds`` says in words what it accepts (docs/scenes.md)."""

    def __init__(self, fn: Callable[[str, Any], Any], bounds: str):
        self.fn = fn
        self.bounds = bounds

    def __call__(self, name: str, value: Any) -> Any:
        return self.fn(name, value)


def checked(bounds: str) -> Callable[[Callable[[str, Any], Any]], Check]:
    """Decorator: the function as a :class:`Check` accepting ``bounds``."""
    return lambda fn: Check(fn, bounds)


def between(low: float, high: float, low_open: bool = False, high_open: bool = False,
            why: str = "") -> Check:
    """A number in [low, high] (an end excluded if ``*_open``)."""
    lo, hi = "(" if low_open else "[", ")" if high_open else "]"

    def check(name: str, value: Any) -> float:
        v = _number(name, value)
        if v < low or (low_open and v == low) or v > high or (high_open and v == high):
            raise SceneError(f"{name} = {v:g} must lie in {lo}{low:g}, {high:g}{hi}{why}")
        return v

    return Check(check, f"{lo}{low:g}, {high:g}{hi}")


@checked("> 0")
def positive(name: str, value: Any) -> float:
    v = _number(name, value)
    if v <= 0:
        raise SceneError(f"{name} = {v:g} must be positive")
    return v


@checked(">= 0")
def non_negative(name: str, value: Any) -> float:
    v = _number(name, value)
    if v < 0:
        raise SceneError(f"{name} = {v:g} must be zero or positive")
    return v


@checked("any finite number")
def finite(name: str, value: Any) -> float:
    return _number(name, value)


@checked(f"[1, {PRESTRETCH_MAX:g}]")
def prestretch_value(name: str, value: Any) -> float:
    v = _number(name, value)
    if v < 1.0:
        raise SceneError(
            f"{name} = {v:g} is below 1: pre-stretch is a stretch ratio (1.0 = none, 1.5 = 150 %), "
            "and a membrane cannot be pre-compressed"
        )
    if v > PRESTRETCH_MAX:
        raise SceneError(f"{name} = {v:g} is above {PRESTRETCH_MAX:g}: no elastomer film stretches that far")
    return v


@checked(f"a number or a pair [l1, l2], each in [1, {PRESTRETCH_MAX:g}]")
def prestretch_spec(name: str, value: Any) -> float | tuple[float, float]:
    """A pre-stretch ratio, or a pair of principal pre-stretches along the pre-stretch axes."""
    if isinstance(value, (list, tuple)):
        if len(value) != 2:
            raise SceneError(
                f"{name} = {show_value(value)}: give one ratio (isotropic, e.g. 1.5) or a pair [l1, l2] "
                "(along the pre-stretch axes, e.g. [1.3, 1.0])")
        return tuple(prestretch_value(f"{name}[{i}]", v) for i, v in enumerate(value))  # type: ignore[return-value]
    return prestretch_value(name, value)


@checked(">= 1")
def permittivity_value(name: str, value: Any) -> float:
    v = _number(name, value)
    if v < 1.0:
        raise SceneError(
            f"{name} = {v:g} is below 1: the relative permittivity of any dielectric is at least 1 "
            "(vacuum); VHB acrylic film is about 4.65"
        )
    return v



@checked("> 0")
def gent_jm_value(name: str, value: Any) -> float:
    v = _number(name, value)
    if v <= 0:
        raise SceneError(
            f"{name} = {v:g} must be positive: it is the Gent law's limit of I1 - 3 (VHB about 33, "
            "a uniaxial locking stretch of 6); a larger value is closer to neo-Hookean"
        )
    return v


@checked(f"1 to {MAX_SWEEP} ratios, each in [1, {PRESTRETCH_MAX:g}]")
def prestretch_list(name: str, value: Any) -> tuple[float, ...]:
    if not isinstance(value, (list, tuple)) or not 0 < len(value) <= MAX_SWEEP:
        raise SceneError(f"{name} must be a list of 1 to {MAX_SWEEP} pre-stretch ratios, e.g. [1.1, 1.3, 1.5]")
    return tuple(prestretch_value(f"{name}[{i}]", v) for i, v in enumerate(value))


@checked("true or false")
def boolean(name: str, value: Any) -> bool:
    if not isinstance(value, bool):
        raise SceneError(f"{name} = {show_value(value)} must be true or false")
    return value


def integer_at_least(low: int, high: int = 10**9) -> Check:
    """A whole number in [low, high]."""
    def check(name: str, value: Any) -> int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise SceneError(f"{name} = {show_value(value)} must be a whole number")
        if value < low:
            raise SceneError(f"{name} = {value} is too small: use at least {low}")
        if value > high:
            raise SceneError(f"{name} = {show_value(value)} is too large: use at most {high}")
        return value

    return Check(check, f"whole number in [{low}, {high}]" if high < 10**9 else f"whole number >= {low}")


def one_of(*choices: str) -> Check:
    """One of the texts ``choices``."""
    def check(name: str, value: Any) -> str:
        if not isinstance(value, str) or value not in choices:
            raise SceneError(f"{name} = {show_value(value)} is not one of {', '.join(map(repr, choices))}")
        return value

    return Check(check, "one of " + ", ".join(f'"{c}"' for c in choices))


def optional(check: Check) -> Check:
    """``check``, or no value (the field's default rule applies)."""
    def wrapped(name: str, value: Any) -> Any:
        return None if value is None else check(name, value)

    return Check(wrapped, f"{check.bounds}, or unset")


@checked(f"3 to {MAX_VERTICES} [x, y] points, |x|, |y| <= 1e5")
def vertex_list(name: str, value: Any) -> tuple[tuple[float, float], ...] | None:
    if value is None:
        return None
    usage = f"{name} must be a list of 3 to {MAX_VERTICES} [x, y] points in mm, e.g. [[0, 0], [40, 0], [20, 30]]"
    if not isinstance(value, (list, tuple)) or not 3 <= len(value) <= MAX_VERTICES:
        raise SceneError(usage)
    return tuple(_point(f"{name}[{k}]", p, usage) for k, p in enumerate(value))


def _point(name: str, value: Any, usage: str) -> tuple[float, float]:
    """One [x, y] point (mm), |x|, |y| <= 1e5; ``usage`` says what the list holds."""
    if not isinstance(value, (list, tuple)) or len(value) != 2:
        raise SceneError(f"{name} = {show_value(value)}: {usage}")
    return between(-1e5, 1e5)(f"{name}[0]", value[0]), between(-1e5, 1e5)(f"{name}[1]", value[1])


MAX_MEMBERS = 32
"""Most cross-members of a frame (their checks are O(k^2))."""


@checked(f"up to {MAX_MEMBERS} members, each two [x, y] points on the outline, |x|, |y| <= 1e5")
def member_list(name: str, value: Any) -> tuple[tuple[tuple[float, float], tuple[float, float]], ...]:
    usage = (f"{name} must be a list of up to {MAX_MEMBERS} members, each the two ends [[x1, y1], [x2, y2]] "
             "(mm) of a straight strip across the frame, e.g. [[[-10, 30], [10, 30]]]")
    if value is None:
        return ()
    if not isinstance(value, (list, tuple)) or len(value) > MAX_MEMBERS:
        raise SceneError(usage)
    out = []
    for k, member in enumerate(value):
        if not isinstance(member, (list, tuple)) or len(member) != 2:
            raise SceneError(f"{name}[{k}] = {show_value(member)}: {usage}")
        out.append(tuple(_point(f"{name}[{k}][{j}]", p, usage) for j, p in enumerate(member)))
    return tuple(out)


@checked(f"up to {MAX_MEMBERS + 1} [x, y] points, |x|, |y| <= 1e5")
def point_list(name: str, value: Any) -> tuple[tuple[float, float], ...]:
    usage = f"{name} must be a list of up to {MAX_MEMBERS + 1} [x, y] points in mm, e.g. [[0, 45]]"
    if value is None:
        return ()
    if not isinstance(value, (list, tuple)) or len(value) > MAX_MEMBERS + 1:
        raise SceneError(usage)
    return tuple(_point(f"{name}[{k}]", p, usage) for k, p in enumerate(value))


def spec(default: Any, check: Check | None, unit: str = "", doc: str = "", bounds: str | None = None) -> Any:
    """A scene field with its default, its check, its unit, a one-line description and what it
    accepts (default: its check's ``bounds``; give it where the section checks more, across fields)."""
    return field(default=default, metadata={"check": check, "unit": unit, "doc": doc,
                                            "bounds": bounds if bounds is not None else check.bounds})


class Section:
    """Base of scene sections: runs every field's check with the field's dotted name."""

    _prefix = ""

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            check = f.metadata.get("check")
            if check is not None:
                object.__setattr__(
                    self, f.name, check(f"{self._prefix}.{f.name}", getattr(self, f.name))
                )

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> "Section":
        if not isinstance(data, dict):
            raise SceneError(f"[{cls._prefix}] must be a table of fields")
        names = {f.name for f in dataclasses.fields(cls) if f.init}
        unknown = sorted(set(data) - names)
        if unknown:
            raise SceneError(
                f"unknown field {cls._prefix}.{unknown[0]}; the fields of [{cls._prefix}] are: "
                + ", ".join(sorted(names))
            )
        return cls(**data)

    def to_dict(self) -> dict[str, Any]:
        out = {}
        for f in dataclasses.fields(self):
            if not f.init:
                continue
            out[f.name] = _as_lists(getattr(self, f.name))
        return out


def _as_lists(value: Any) -> Any:
    """Nested tuples (points, members) as nested lists, as TOML and JSON write them."""
    return [_as_lists(v) for v in value] if isinstance(value, tuple) else value
