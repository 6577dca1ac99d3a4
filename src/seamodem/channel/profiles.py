"""Radial-speed profiles v_r(t) for the pure-Doppler mode (paper 003 §III.C).

A profile gives the closing speed v_r(t) [m/s] (positive when closing) and its
integral D(t) = ∫₀ᵗ v_r(u) du [m] in closed form, so the received waveform
s̃(t) = s(t + D(t)/c) (paper 003 eq 14) is exact for any profile here.
Profiles add up: paper 003 writes v_r = v_rv (vehicle) + v_rd (drift) +
v_rs (surface waves), which is ``SumProfile([vehicle, drift, surface])``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

from ..errors import ConfigError

__all__ = [
    "DopplerProfile",
    "ConstantProfile",
    "RampProfile",
    "SinusoidalProfile",
    "SampledProfile",
    "SumProfile",
    "PROFILE_KINDS",
    "profile_from_table",
]


def _finite(name: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ConfigError(name, f"must be a finite number, got {value!r}")
    return float(value)


class DopplerProfile:
    """Base class: ``speed(t)`` [m/s] and ``displacement(t)`` = ∫₀ᵗ v_r [m].

    Subclasses are frozen dataclasses that also serialize with
    :meth:`to_dict` (the scenario file's ``doppler.profile`` entry).
    """

    def speed(self, t_s) -> np.ndarray:
        """Closing speed v_r(t).

        Parameters
        ----------
        t_s : float or array_like
            Times [s].

        Returns
        -------
        numpy.ndarray
            v_r [m/s], positive when closing, same shape as ``t_s``.
        """
        raise NotImplementedError

    def displacement(self, t_s) -> np.ndarray:
        """Range decrease D(t) = ∫₀ᵗ v_r(u) du, in closed form.

        Parameters
        ----------
        t_s : float or array_like
            Times [s].

        Returns
        -------
        numpy.ndarray
            D(t) [m], same shape as ``t_s``; D(0) = 0.
        """
        raise NotImplementedError

    def max_abs_speed(self, t0_s: float, t1_s: float) -> float:
        """Largest |v_r| over [t0, t1] (an upper bound for sums).

        Parameters
        ----------
        t0_s, t1_s : float
            Interval ends [s].

        Returns
        -------
        float
            max |v_r| [m/s] (the base class samples 4097 points).
        """
        t = np.linspace(t0_s, t1_s, 4097)
        return float(np.max(np.abs(self.speed(t))))

    def to_dict(self) -> dict:
        """The profile as a JSON-ready dict with a ``"kind"`` key.

        Returns
        -------
        dict
            ``kind`` and the constructor's fields.
        """
        raise NotImplementedError


@dataclass(frozen=True)
class ConstantProfile(DopplerProfile):
    """v_r(t) = v_mps.

    Attributes
    ----------
    v_mps : float
        Constant closing speed [m/s], positive when closing.
    label : str, optional
        Free name of the component (e.g. ``"vehicle"``), kept in
        :meth:`to_dict`; ``""`` for none.
    """

    v_mps: float
    label: str = ""

    def __post_init__(self):
        object.__setattr__(self, "v_mps", _finite("v_mps", self.v_mps))

    def speed(self, t_s):
        return np.full(np.shape(t_s), self.v_mps)

    def displacement(self, t_s):
        return self.v_mps * np.asarray(t_s, dtype=float)

    def max_abs_speed(self, t0_s, t1_s):
        return abs(self.v_mps)

    def to_dict(self):
        return {"kind": "constant", "v_mps": self.v_mps, "label": self.label}


@dataclass(frozen=True)
class RampProfile(DopplerProfile):
    """v_r goes linearly from ``v0_mps`` at ``t0_s`` to ``v1_mps`` at ``t1_s``; constant outside.

    Attributes
    ----------
    v0_mps : float
        Closing speed up to ``t0_s`` [m/s].
    v1_mps : float
        Closing speed from ``t1_s`` on [m/s].
    t0_s : float
        Start of the ramp [s].
    t1_s : float
        End of the ramp [s], > ``t0_s``.
    label : str, optional
        Free name of the component (e.g. ``"vehicle"``), kept in
        :meth:`to_dict`; ``""`` for none.
    """

    v0_mps: float
    v1_mps: float
    t0_s: float
    t1_s: float
    label: str = ""

    def __post_init__(self):
        for name in ("v0_mps", "v1_mps", "t0_s", "t1_s"):
            object.__setattr__(self, name, _finite(name, getattr(self, name)))
        if self.t1_s <= self.t0_s:
            raise ConfigError("t1_s", f"must be > t0_s = {self.t0_s:g} s, got {self.t1_s:g}")

    @property
    def _slope(self) -> float:
        return (self.v1_mps - self.v0_mps) / (self.t1_s - self.t0_s)

    def speed(self, t_s):
        t = np.clip(np.asarray(t_s, dtype=float), self.t0_s, self.t1_s)
        return self.v0_mps + self._slope * (t - self.t0_s)

    def _antiderivative(self, t):
        # F(t) with F' = v, F(t0) = 0; piecewise: constant v0 before, quadratic on the ramp, v1 after
        a = self._slope
        tc = np.clip(t, self.t0_s, self.t1_s)
        ramp = self.v0_mps * (tc - self.t0_s) + 0.5 * a * (tc - self.t0_s) ** 2
        return ramp + self.v0_mps * np.minimum(t - self.t0_s, 0.0) + self.v1_mps * np.maximum(t - self.t1_s, 0.0)

    def displacement(self, t_s):
        t = np.asarray(t_s, dtype=float)
        return self._antiderivative(t) - self._antiderivative(np.zeros(()))

    def max_abs_speed(self, t0_s, t1_s):
        return max(abs(self.v0_mps), abs(self.v1_mps))

    def to_dict(self):
        return {"kind": "ramp", "v0_mps": self.v0_mps, "v1_mps": self.v1_mps, "t0_s": self.t0_s,
                "t1_s": self.t1_s, "label": self.label}


@dataclass(frozen=True)
class SinusoidalProfile(DopplerProfile):
    """Surface-wave motion: v_r(t) = amplitude · sin(2π f t + phase).

    Attributes
    ----------
    amplitude_mps : float
        Peak closing speed [m/s].
    frequency_hz : float
        Frequency of the motion f [Hz], > 0.
    phase_rad : float, optional
        Phase at t = 0 [rad]; 0 starts at v_r = 0, accelerating.
    label : str, optional
        Free name of the component (e.g. ``"vehicle"``), kept in
        :meth:`to_dict`; ``""`` for none.
    """

    amplitude_mps: float
    frequency_hz: float
    phase_rad: float = 0.0
    label: str = ""

    def __post_init__(self):
        for name in ("amplitude_mps", "frequency_hz", "phase_rad"):
            object.__setattr__(self, name, _finite(name, getattr(self, name)))
        if self.frequency_hz <= 0:
            raise ConfigError("frequency_hz", f"must be > 0, got {self.frequency_hz!r}")

    def speed(self, t_s):
        return self.amplitude_mps * np.sin(2 * np.pi * self.frequency_hz * np.asarray(t_s, dtype=float) + self.phase_rad)

    def displacement(self, t_s):
        w = 2 * np.pi * self.frequency_hz
        t = np.asarray(t_s, dtype=float)
        return self.amplitude_mps / w * (math.cos(self.phase_rad) - np.cos(w * t + self.phase_rad))

    def max_abs_speed(self, t0_s, t1_s):
        return abs(self.amplitude_mps)

    def to_dict(self):
        return {"kind": "sinusoid", "amplitude_mps": self.amplitude_mps, "frequency_hz": self.frequency_hz,
                "phase_rad": self.phase_rad, "label": self.label}


@dataclass(frozen=True, eq=False)
class SampledProfile(DopplerProfile):
    """An arbitrary v_r(t) given at sample times, linear in between (held outside).

    The integral of the piecewise-linear speed is exact (trapezoids, then a
    quadratic inside the current interval).

    Attributes
    ----------
    t_s : numpy.ndarray
        Sample times [s], shape ``(n_points,)``, strictly increasing, n_points ≥ 2.
    v_mps : numpy.ndarray
        Closing speeds at ``t_s`` [m/s], shape ``(n_points,)``.
    label : str, optional
        Free name of the component (e.g. ``"vehicle"``), kept in
        :meth:`to_dict`; ``""`` for none.
    """

    t_s: np.ndarray
    v_mps: np.ndarray
    label: str = ""
    _cum: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        t = np.asarray(self.t_s, dtype=float)
        v = np.asarray(self.v_mps, dtype=float)
        if t.ndim != 1 or t.shape != v.shape or t.size < 2:
            raise ConfigError("v_mps", f"needs as many values as t_s (≥ 2), got {v.size} and {t.size}")
        if not (np.all(np.isfinite(t)) and np.all(np.isfinite(v))):
            raise ConfigError("v_mps", "t_s and v_mps must be finite")
        if np.any(np.diff(t) <= 0):
            raise ConfigError("t_s", "must be strictly increasing")
        object.__setattr__(self, "t_s", t)
        object.__setattr__(self, "v_mps", v)
        cum = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(t))])
        object.__setattr__(self, "_cum", cum)

    def speed(self, t_s):
        return np.interp(t_s, self.t_s, self.v_mps)

    def _antiderivative(self, t):
        t = np.asarray(t, dtype=float)
        tk, vk = self.t_s, self.v_mps
        i = np.clip(np.searchsorted(tk, t, side="right") - 1, 0, tk.size - 2)
        dt = np.clip(t, tk[0], tk[-1]) - tk[i]
        slope = (vk[i + 1] - vk[i]) / (tk[i + 1] - tk[i])
        inside = self._cum[i] + vk[i] * dt + 0.5 * slope * dt**2
        return inside + vk[0] * np.minimum(t - tk[0], 0.0) + vk[-1] * np.maximum(t - tk[-1], 0.0)

    def displacement(self, t_s):
        return self._antiderivative(np.asarray(t_s, dtype=float)) - self._antiderivative(np.zeros(()))

    def max_abs_speed(self, t0_s, t1_s):
        return float(np.max(np.abs(self.v_mps)))

    def to_dict(self):
        return {"kind": "sampled", "t_s": self.t_s.tolist(), "v_mps": self.v_mps.tolist(), "label": self.label}


@dataclass(frozen=True)
class SumProfile(DopplerProfile):
    """The sum of several profiles (vehicle + drift + surface, paper 003 §III.C).

    Parameters
    ----------
    components : sequence of DopplerProfile
        The profiles to add.

    Attributes
    ----------
    components : tuple of DopplerProfile
        The profiles, in the order given.
    """

    components: tuple[DopplerProfile, ...]

    def __init__(self, components: Sequence[DopplerProfile]):
        object.__setattr__(self, "components", tuple(components))

    def speed(self, t_s):
        return sum((p.speed(t_s) for p in self.components), np.zeros(np.shape(t_s)))

    def displacement(self, t_s):
        return sum((p.displacement(t_s) for p in self.components), np.zeros(np.shape(t_s)))

    def max_abs_speed(self, t0_s, t1_s):
        return sum(p.max_abs_speed(t0_s, t1_s) for p in self.components)

    def to_dict(self):
        return {"kind": "sum", "components": [p.to_dict() for p in self.components]}


#: [doppler] component kind → (profile class, its keys)
PROFILE_KINDS = {
    "constant": (ConstantProfile, ("v_mps",)),
    "ramp": (RampProfile, ("v0_mps", "v1_mps", "t0_s", "t1_s")),
    "sinusoid": (SinusoidalProfile, ("amplitude_mps", "frequency_hz", "phase_rad")),
    "sampled": (SampledProfile, ("t_s", "v_mps")),
}


def profile_from_table(i: int, table: Any) -> DopplerProfile:
    """One component of a scenario's [doppler] table as its profile.

    Parameters
    ----------
    i : int
        The component's index, for the error messages (``doppler.components[i].key``).
    table : dict
        ``kind`` (a key of :data:`PROFILE_KINDS`), an optional ``label``, and that kind's keys.

    Returns
    -------
    DopplerProfile
        The profile.

    Raises
    ------
    ConfigError
        Not a table, an unknown kind or key, a missing key, an invalid value.
    """
    where = f"doppler.components[{i}]"
    if not isinstance(table, dict):
        raise ConfigError(where, f"must be a table, got {table!r}")
    kind = table.get("kind")
    if kind not in PROFILE_KINDS:
        raise ConfigError(f"{where}.kind", f"must be one of {', '.join(PROFILE_KINDS)}, got {kind!r}")
    cls, keys = PROFILE_KINDS[kind]
    for key in table:
        if key not in ("kind", "label", *keys):
            raise ConfigError(f"{where}.{key}", f"unknown scenario key for kind {kind!r} (known: kind, label, {', '.join(keys)})")
    args = {k: v for k, v in table.items() if k != "kind"}
    try:
        return cls(**args)
    except ConfigError as exc:
        raise ConfigError(f"{where}.{exc.parameter}", str(exc).split(": ", 1)[1]) from None
    except TypeError as exc:
        raise ConfigError(where, f"missing a key for kind {kind!r} (needs {', '.join(keys)}): {exc}") from None
