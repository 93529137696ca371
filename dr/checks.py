"""Checks of the numbers a DR model is built from; each raises DRError naming the argument."""

from __future__ import annotations

from typing import Sequence

import numpy as np

from .errors import DRError


def positive(name: str, value: float) -> float:
    """``value`` as a float, if it is a finite number > 0."""
    v = float(value)
    if not np.isfinite(v) or v <= 0:
        raise DRError(f"{name} = {value!r} must be a positive number")
    return v


def prestretch_tensor(value: Sequence[Sequence[float]]) -> np.ndarray:
    """``value`` as a pre-stretch tensor: a symmetric positive-definite (2, 2) array."""
    P = np.asarray(value, dtype=float)
    if (P.shape != (2, 2) or not np.all(np.isfinite(P)) or abs(P[0, 1] - P[1, 0]) > 1e-12 * np.abs(P).max()
            or np.linalg.eigvalsh(P).min() <= 0.0):
        raise DRError("a pre-stretch tensor must be a symmetric positive-definite (2, 2) array")
    return P


def unit(name: str, v: Sequence[float]) -> np.ndarray:
    """The unit vector along ``v``, a finite non-zero 3-vector."""
    a = np.asarray(v, dtype=float).reshape(-1)
    if a.shape != (3,) or not np.all(np.isfinite(a)) or np.linalg.norm(a) == 0:
        raise DRError(f"{name} must be a non-zero 3-vector")
    return a / np.linalg.norm(a)
