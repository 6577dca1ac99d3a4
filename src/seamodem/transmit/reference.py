"""Reference waveforms other than seamodem's frame: LFM and HFM chirps, m-sequence pings, templates.

A :class:`ReferenceWaveform` is a frozen, validated configuration (JSON/TOML
round trip). Every reference is handled through its analytic signal
s_a(t) = b(t) e^{j2π f_c t}, f_c the centre of its band [f_low, f_high] and b
the complex envelope, defined for 0 ≤ t ≤ duration (zero outside):

* ``lfm``: b(t) = w(t) e^{j2π(f_low − f_c) t + jπ (B/T) t²} (down-sweep mirrored);
* ``hfm``: instantaneous frequency f(t) = f_0 / (1 − k t), f_0 = f_low,
  k = (f_high − f_low)/(f_high T) (down-sweep: f_0 = f_high, k < 0),
  phase φ(t) = −(2π f_0 / k) ln(1 − k t);
* ``pn``: a maximal-length sequence of 2^m − 1 chips (``scipy.signal.max_len_seq``),
  ±1 BPSK, SRRC-shaped at the chip rate, on a carrier;
* ``template``: an excerpt of a recording (WAV or ``.mat``), any waveform.

Doppler is a time scale (SPEC §1): the received reference is
s((1 + ε)(t − t_a)), ε = v_r/c.

HFM delay–Doppler coupling
--------------------------
An HFM is Doppler invariant: s((1 + ε) t) = s(t + δ(ε)) e^{jψ}, up to its
envelope, with δ(ε) = (1 − 1/(1 + ε))/k ≈ ε/k (:func:`hfm_coupling_s`). A
replica matched at the wrong scale still correlates fully, but its peak sits
δ early: the arrival time and the Doppler scale lie on one ridge, and an error
Δε in the Doppler becomes an error Δε/k in the arrival time. The receiver
measures the pair jointly on the ridge (time-scaled replicas, so the
correction t_a = t_peak + δ(ε) is built in), and the bounds are the joint ones
(:func:`reference_crlb`); a pre/postamble pair of known spacing gives ε
independently of the ridge (their common offset cancels in the spacing).
"""

from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ConfigError, InputFileError, value_text

__all__ = [
    "REFERENCE_KINDS",
    "WINDOWS",
    "ReferenceWaveform",
    "Replica",
    "parse_reference",
    "load_references",
    "reference_waveform",
    "reference_replica",
    "hfm_coupling_s",
    "reference_crlb",
    "ReferenceBound",
    "REFERENCE_SIDECAR_FORMAT",
    "emission_times",
    "write_reference_beacon",
]

REFERENCE_KINDS = ("lfm", "hfm", "pn", "template")
WINDOWS = ("tukey", "hann", "rect")
#: oversampling of the envelope tables (PN, template) over the input rate: linear interpolation error < −70 dB
_TABLE_OVERSAMPLING = 8


def _finite_positive(name: str, value: float) -> None:
    if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
        raise ConfigError(name, f"must be a positive number, got {value!r}")


@dataclass(frozen=True, kw_only=True)
class ReferenceWaveform:
    """A known waveform to range on.

    Parameters
    ----------
    kind : {"lfm", "hfm", "pn", "template"}
    name : str
        Label written in each record's ``reference`` column (default the kind and band).
    f_low_hz, f_high_hz : float
        Band [Hz]: the sweep of a chirp, the stated band of a template (default:
        the band holding 99 % of the template's energy). For ``pn`` they follow
        from the carrier, chip rate and roll-off.
    duration_s : float
        Chirp length [s]; for ``pn`` and ``template`` it follows from the rest.
    window : {"tukey", "hann", "rect"}
        Amplitude window of a chirp.
    taper : float
        Tukey window's tapered fraction in [0, 1].
    down : bool
        Down-sweep (f_high to f_low).
    carrier_hz, chip_rate_hz : float
        PN carrier and chip rate [Hz].
    degree : int
        PN m-sequence degree m (2^m − 1 chips), 3 … 16.
    rolloff : float
        PN chips' SRRC roll-off in [0, 1].
    file : str
        Template recording (WAV or ``.mat``).
    mat_variable : str
        Template: the ``.mat`` variable holding the samples.
    sample_rate_hz : float
        Template: the sample rate when the file does not hold one (``.mat``) [Hz].
    start_s, stop_s : float
        Template excerpt [s] (stop 0: to the end).
    channel : int
        Template's channel (0-based).
    postamble_s : float
        Packets bracketed by this reference: the postamble (train) starts this
        long after the preamble (train) (first chirp to first chirp) [s]; 0 =
        no postamble.
    train_count : int
        Chirps in the preamble train (1: a single preamble ping), each
        ``train_spacing_s`` after the previous one.
    train_spacing_s : float
        Start-to-start spacing of the chirps in a train [s] (with
        ``train_count`` > 1 or ``postamble_count`` > 1).
    postamble_count : int
        Chirps in the postamble train (0: as many as the preamble's when
        ``postamble_s`` is set).

    Examples
    --------
    A research packet: 4 chirps 0.25 s apart, 3 more 8.27 s later.

    >>> ref = ReferenceWaveform(kind="lfm", f_low_hz=19e3, f_high_hz=29e3, duration_s=0.05, window="rect",
    ...                         train_count=4, train_spacing_s=0.25, postamble_s=8.27, postamble_count=3)
    >>> [(round(t, 2), role) for t, role, _ in ref.packet()][3:5]
    [(0.75, 'preamble'), (8.27, 'postamble')]
    """

    kind: str
    name: str = ""
    f_low_hz: float = 0.0
    f_high_hz: float = 0.0
    duration_s: float = 0.0
    window: str = "tukey"
    taper: float = 0.1
    down: bool = False
    carrier_hz: float = 0.0
    chip_rate_hz: float = 0.0
    degree: int = 7
    rolloff: float = 0.5
    file: str = ""
    mat_variable: str = ""
    sample_rate_hz: float = 0.0
    start_s: float = 0.0
    stop_s: float = 0.0
    channel: int = 0
    postamble_s: float = 0.0
    train_count: int = 1
    train_spacing_s: float = 0.0
    postamble_count: int = 0

    def __post_init__(self):
        if self.kind not in REFERENCE_KINDS:
            raise ConfigError("kind", f"must be one of {', '.join(REFERENCE_KINDS)}, got {self.kind!r}")
        if self.kind in ("lfm", "hfm"):
            _finite_positive("f_low_hz", self.f_low_hz)
            _finite_positive("duration_s", self.duration_s)
            if not self.f_high_hz > self.f_low_hz:
                raise ConfigError("f_high_hz", f"must exceed f_low_hz = {self.f_low_hz:g} Hz, got {self.f_high_hz!r}")
            if self.window not in WINDOWS:
                raise ConfigError("window", f"must be one of {', '.join(WINDOWS)}, got {self.window!r}")
            if not 0 <= self.taper <= 1:
                raise ConfigError("taper", f"must be in [0, 1], got {self.taper!r}")
        elif self.kind == "pn":
            _finite_positive("carrier_hz", self.carrier_hz)
            _finite_positive("chip_rate_hz", self.chip_rate_hz)
            if not (isinstance(self.degree, int) and 3 <= self.degree <= 16):
                raise ConfigError("degree", f"must be an integer in 3 … 16, got {self.degree!r}")
            if not 0 <= self.rolloff <= 1:
                raise ConfigError("rolloff", f"must be in [0, 1], got {self.rolloff!r}")
            half = (1 + self.rolloff) * self.chip_rate_hz / 2
            if half >= self.carrier_hz:
                raise ConfigError("chip_rate_hz", f"band {self.carrier_hz - half:g} Hz reaches below 0 Hz")
            object.__setattr__(self, "f_low_hz", self.carrier_hz - half)
            object.__setattr__(self, "f_high_hz", self.carrier_hz + half)
            object.__setattr__(self, "duration_s", (2**self.degree - 1 + _PN_SPAN) / self.chip_rate_hz)
        else:
            if not self.file:
                raise ConfigError("file", "a template reference needs the recording it is cut from")
            if self.start_s < 0 or (self.stop_s and self.stop_s <= self.start_s):
                raise ConfigError("stop_s", f"excerpt [{self.start_s!r}, {self.stop_s!r}] s is empty or negative")
            if self.f_low_hz or self.f_high_hz:
                if not 0 < self.f_low_hz < self.f_high_hz:
                    raise ConfigError("f_high_hz", f"band must satisfy 0 < f_low < f_high, got {self.f_low_hz!r}, {self.f_high_hz!r}")
        if not (math.isfinite(self.postamble_s) and self.postamble_s >= 0):
            raise ConfigError("postamble_s", f"must be >= 0, got {self.postamble_s!r}")
        if self.postamble_s and self.kind != "template" and self.postamble_s <= self.duration_s:
            raise ConfigError("postamble_s", f"must exceed the reference's duration {self.duration_s:g} s, got {self.postamble_s!r}")
        for name in ("train_count", "postamble_count"):
            value = getattr(self, name)
            if not (isinstance(value, int) and not isinstance(value, bool) and 0 <= value <= 64):
                raise ConfigError(name, f"must be an integer in 0 … 64, got {value_text(value)}")
        if self.train_count < 1:
            raise ConfigError("train_count", f"must be at least 1, got {self.train_count}")
        if self.postamble_count and not self.postamble_s:
            raise ConfigError("postamble_count", "needs postamble_s (where the postamble train starts)")
        if not (isinstance(self.train_spacing_s, (int, float)) and math.isfinite(self.train_spacing_s)
                and self.train_spacing_s >= 0):
            raise ConfigError("train_spacing_s", f"must be >= 0, got {value_text(self.train_spacing_s)}")
        if max(self.train_count, self.postamble_count) > 1:
            if self.kind != "template" and self.train_spacing_s <= self.duration_s:
                raise ConfigError("train_spacing_s", f"must exceed the reference's duration {self.duration_s:g} s "
                                  f"for trains of several chirps, got {self.train_spacing_s!r}")
            last_pre = (self.train_count - 1) * self.train_spacing_s
            if self.postamble_s and self.postamble_s <= last_pre + self.duration_s:
                raise ConfigError("postamble_s", f"must start after the preamble train ends "
                                  f"({last_pre + self.duration_s:g} s), got {self.postamble_s!r}")
        if not self.name:
            object.__setattr__(self, "name", self.default_name())

    def packet(self) -> list[tuple[float, str, int]]:
        """Every chirp of one packet: (emission offset from the first chirp [s], role, position in its train).

        Roles: "ping" (a lone ping: no train, no postamble), "preamble", "postamble".
        """
        n_post = (self.postamble_count or self.train_count) if self.postamble_s else 0
        if self.train_count == 1 and not n_post:
            return [(0.0, "ping", 0)]
        out = [(i * self.train_spacing_s, "preamble", i) for i in range(self.train_count)]
        out += [(self.postamble_s + i * self.train_spacing_s, "postamble", i) for i in range(n_post)]
        return out

    def default_name(self) -> str:
        if self.kind == "pn":
            return f"pn{self.degree}_{self.carrier_hz / 1e3:g}k"
        if self.kind == "template":
            return Path(self.file).stem
        return f"{self.kind}_{self.f_low_hz / 1e3:g}-{self.f_high_hz / 1e3:g}k_{self.duration_s * 1e3:g}ms"

    @property
    def centre_hz(self) -> float:
        """f_c, the centre of the band [Hz]."""
        return 0.5 * (self.f_low_hz + self.f_high_hz)

    @property
    def bandwidth_hz(self) -> float:
        """f_high − f_low [Hz]: the band in which the in-band SNR is defined."""
        return self.f_high_hz - self.f_low_hz

    def to_dict(self) -> dict[str, Any]:
        """Only the fields that matter for this kind, plus ``kind`` and ``name``."""
        keep = {
            "lfm": ("f_low_hz", "f_high_hz", "duration_s", "window", "taper", "down"),
            "hfm": ("f_low_hz", "f_high_hz", "duration_s", "window", "taper", "down"),
            "pn": ("carrier_hz", "chip_rate_hz", "degree", "rolloff"),
            "template": ("file", "mat_variable", "sample_rate_hz", "start_s", "stop_s", "channel", "f_low_hz", "f_high_hz"),
        }[self.kind]
        out = {"kind": self.kind, "name": self.name, **{k: getattr(self, k) for k in keep}}
        for key in ("postamble_s", "train_count", "train_spacing_s", "postamble_count"):
            if getattr(self, key) != getattr(ReferenceWaveform, key):
                out[key] = getattr(self, key)
        return out

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> ReferenceWaveform:
        """Inverse of :meth:`to_dict`; unknown keys are an error naming them."""
        names = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(data) - names)
        if unknown:
            raise ConfigError(unknown[0], f"is not a reference parameter (known: {', '.join(sorted(names))})")
        if "kind" not in data:
            raise ConfigError("kind", "missing: say which waveform (lfm, hfm, pn or template)")
        return cls(**data)


#: PN chips' SRRC span [chips]; the ping lasts (2^m − 1 + span)/R
_PN_SPAN = 8


def _window(ref: ReferenceWaveform, u: np.ndarray) -> np.ndarray:
    """Amplitude window on u = t/T ∈ [0, 1] (0 outside)."""
    inside = (u >= 0) & (u <= 1)
    if ref.window == "hann":
        return np.where(inside, np.sin(np.pi * u) ** 2, 0.0)
    if ref.window == "rect" or ref.taper == 0:
        return inside.astype(float)
    a = ref.taper
    edge = np.minimum(u, 1 - u)
    ramp = 0.5 * (1 - np.cos(2 * np.pi * np.minimum(edge, a / 2) / a))
    return np.where(inside, ramp, 0.0)


def _window_derivative(ref: ReferenceWaveform, u: np.ndarray) -> np.ndarray:
    """dw/du of :func:`_window`."""
    inside = (u >= 0) & (u <= 1)
    if ref.window == "hann":
        return np.where(inside, np.pi * np.sin(2 * np.pi * u), 0.0)
    if ref.window == "rect" or ref.taper == 0:
        return np.zeros_like(u)
    a = ref.taper
    edge = np.minimum(u, 1 - u)
    slope = np.pi / a * np.sin(2 * np.pi * edge / a) * np.where(u < 0.5, 1.0, -1.0)
    return np.where(inside & (edge < a / 2), slope, 0.0)


def hfm_coupling_s(ref: ReferenceWaveform, eps) -> np.ndarray:
    """δ(ε) = (1 − 1/(1 + ε))/k: how much earlier an HFM's unscaled-replica peak sits for a scale 1 + ε [s].

    Notes
    -----
    With f(t) = f_0/(1 − k t), φ((1 + ε)t) = φ(t + δ) + const for
    1 − k(t + δ) = (1 − k(1 + ε)t)/(1 + ε), i.e. δ = (1 − 1/(1 + ε))/k ≈ ε/k:
    3.4 ms per m/s for 19–29 kHz in 50 ms (k = 6.9 s⁻¹, c = 1500 m/s).
    """
    if ref.kind != "hfm":
        raise ConfigError("kind", f"the delay–Doppler coupling formula is for HFM chirps, got {ref.kind!r}")
    k = _hfm_k(ref)
    eps = np.asarray(eps, dtype=float)
    return (1 - 1 / (1 + eps)) / k


def _hfm_k(ref: ReferenceWaveform) -> float:
    if ref.down:
        return -(ref.f_high_hz - ref.f_low_hz) / (ref.f_low_hz * ref.duration_s)
    return (ref.f_high_hz - ref.f_low_hz) / (ref.f_high_hz * ref.duration_s)


def _chirp_phase(ref: ReferenceWaveform, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Phase φ(t) [rad] (of the passband signal) and instantaneous frequency f(t) [Hz] of a chirp."""
    T, B = ref.duration_s, ref.bandwidth_hz
    if ref.kind == "lfm":
        f0, rate = (ref.f_high_hz, -B / T) if ref.down else (ref.f_low_hz, B / T)
        return 2 * np.pi * (f0 * t + 0.5 * rate * t**2), f0 + rate * t
    f0 = ref.f_high_hz if ref.down else ref.f_low_hz
    k = _hfm_k(ref)
    arg = np.maximum(1 - k * t, 1e-12)
    return -2 * np.pi * f0 / k * np.log(arg), f0 / arg


def _compiled_chirp(ref: ReferenceWaveform, t_s: np.ndarray, t_arrival_s: float, eps: float, carrier_hz: float, *,
                    with_derivative: bool) -> tuple[np.ndarray, np.ndarray | None]:
    """q = w(u) e^{j(φ(u) − 2π f_rx t)} and ∂q/∂u of a chirp in one compiled pass (:mod:`._chirp_kernel`).

    The same formulas as :func:`_window`, :func:`_window_derivative` and :func:`_chirp_phase` (tested against
    them), without a dozen numpy passes per call: 130–160 → 50 µs for 1300 samples.
    """
    from . import _chirp_kernel as kernel

    t = np.ascontiguousarray(t_s, dtype=float).reshape(-1)
    T, B = ref.duration_s, ref.bandwidth_hz
    if ref.kind == "hfm":
        f0, rate_or_k = (ref.f_high_hz if ref.down else ref.f_low_hz), _hfm_k(ref)
    else:
        f0, rate_or_k = (ref.f_high_hz, -B / T) if ref.down else (ref.f_low_hz, B / T)
    window = kernel.HANN if ref.window == "hann" else kernel.RECT if (ref.window == "rect" or ref.taper == 0) else kernel.TUKEY
    q = np.empty(len(t), complex)
    dq = np.empty(len(t) if with_derivative else 0, complex)
    kernel.fill_chirp(t, float(t_arrival_s), float(eps), float(carrier_hz), ref.kind == "hfm", float(f0),
                      float(rate_or_k), float(T), window, float(ref.taper), q, dq, with_derivative)
    shape = np.shape(t_s)
    return q.reshape(shape), (dq.reshape(shape) if with_derivative else None)


class Replica:
    """A reference's complex envelope b(t) (carrier f_c) and its derivative, at any time.

    Chirps are evaluated in closed form; PN pings and templates from a table
    oversampled 8× over their rate, read by linear interpolation.

    Parameters
    ----------
    reference : ReferenceWaveform
    table : numpy.ndarray, optional
        Envelope samples (PN, template) at ``table_rate_hz``, first sample at t = 0.
    table_rate_hz : float
    """

    def __init__(self, reference: ReferenceWaveform, table: np.ndarray | None = None, table_rate_hz: float = 0.0):
        self.reference = reference
        self.centre_hz = reference.centre_hz
        #: what receivers derive from this replica once (sampled spectra, sidelobe level), keyed by their settings
        self.memo: dict = {}
        self._table = table
        self._rate = float(table_rate_hz)
        if table is not None:
            self._slope = np.diff(table, append=table[-1:]) * self._rate
            self.duration_s = (len(table) - 1) / self._rate
        else:
            self.duration_s = reference.duration_s

    def envelope(self, t_s: np.ndarray) -> np.ndarray:
        """b(t), zero outside [0, duration]."""
        t = np.asarray(t_s, dtype=float)
        ref = self.reference
        if self._table is None:
            phase, _ = _chirp_phase(ref, np.clip(t, 0, ref.duration_s))
            w = _window(ref, t / ref.duration_s)
            return w * np.exp(1j * (phase - 2 * np.pi * self.centre_hz * t))
        pos = t * self._rate
        i = np.clip(np.floor(pos).astype(np.int64), 0, len(self._table) - 2)
        frac = pos - i
        out = self._table[i] * (1 - frac) + self._table[i + 1] * frac
        return np.where((pos >= 0) & (pos <= len(self._table) - 1), out, 0.0)

    def derivative(self, t_s: np.ndarray) -> np.ndarray:
        """db/dt [1/s] (chirps: closed form; tables: the slope of the interpolant)."""
        t = np.asarray(t_s, dtype=float)
        ref = self.reference
        if self._table is None:
            T = ref.duration_s
            tc = np.clip(t, 0, T)
            phase, f = _chirp_phase(ref, tc)
            rot = np.exp(1j * (phase - 2 * np.pi * self.centre_hz * t))
            w, dw = _window(ref, t / T), _window_derivative(ref, t / T) / T
            return (dw + 2j * np.pi * (f - self.centre_hz) * w) * rot
        pos = t * self._rate
        i = np.clip(np.floor(pos).astype(np.int64), 0, len(self._table) - 2)
        return np.where((pos >= 0) & (pos <= len(self._table) - 1), self._slope[i], 0.0)

    def scaled_with_derivative(
        self, t_s: np.ndarray, *, t_arrival_s: float, eps: float, carrier_hz: float
    ) -> tuple[np.ndarray, np.ndarray]:
        """q of :meth:`scaled` and ∂q/∂u (u = (1 + ε)(t − t_a)): ∂q/∂t_a = −(1 + ε)∂q/∂u, ∂q/∂ε = (t − t_a)∂q/∂u."""
        t = np.asarray(t_s, dtype=float)
        if self._table is None:
            # chirps: one compiled pass for both (s_a' = (w' + j2π f w) e^{jφ})
            return _compiled_chirp(self.reference, t, t_arrival_s, eps, carrier_hz, with_derivative=True)
        u = (1 + eps) * (t - t_arrival_s)
        rot = np.exp(2j * np.pi * (self.centre_hz * u - carrier_hz * t))
        b = self.envelope(u)
        return b * rot, (self.derivative(u) + 2j * np.pi * self.centre_hz * b) * rot

    def scaled(self, t_s: np.ndarray, *, t_arrival_s: float, eps: float, carrier_hz: float) -> np.ndarray:
        """Complex envelope at carrier ``carrier_hz`` of s_a((1 + ε)(t − t_a)): the received replica.

        q(t) = b(u) e^{j2π(f_c u − f_rx t)}, u = (1 + ε)(t − t_a).
        """
        t = np.asarray(t_s, dtype=float)
        if self._table is None:  # chirps: w(u) e^{j(φ(u) − 2π f_rx t)} in one compiled pass
            return _compiled_chirp(self.reference, t, t_arrival_s, eps, carrier_hz, with_derivative=False)[0]
        u = (1 + eps) * (t - t_arrival_s)
        return self.envelope(u) * np.exp(2j * np.pi * (self.centre_hz * u - carrier_hz * t))


def _pn_table(ref: ReferenceWaveform) -> tuple[np.ndarray, float]:
    import scipy.signal

    from .pulse import srrc_pulse

    chips = 1.0 - 2.0 * scipy.signal.max_len_seq(ref.degree)[0].astype(float)
    per_chip = 16 * _TABLE_OVERSAMPLING // 2
    rate = ref.chip_rate_hz * per_chip
    Tc = 1.0 / ref.chip_rate_hz
    n = int(round(ref.duration_s * rate)) + 1
    t = np.arange(n) / rate
    centres = (_PN_SPAN / 2 + np.arange(chips.size)) * Tc
    b = np.zeros(n)
    half = _PN_SPAN / 2 * Tc
    for k, c in enumerate(chips):
        lo, hi = int(math.ceil((centres[k] - half) * rate)), int(math.floor((centres[k] + half) * rate)) + 1
        b[lo:hi] += c * srrc_pulse(t[lo:hi] - centres[k], Tc, ref.rolloff) * math.sqrt(Tc)
    return b.astype(complex), rate


def _template_table(ref: ReferenceWaveform, base_dir: Path | None) -> tuple[np.ndarray, float, ReferenceWaveform]:
    """Envelope table of a template excerpt, and the reference with its band filled in when not stated."""
    import scipy.signal

    from ..io.mat import read_recording

    path = Path(ref.file)
    if not path.is_absolute() and base_dir is not None:
        path = base_dir / path
    x, fs = read_recording(
        path, mat_variable=ref.mat_variable or None, sample_rate_hz=ref.sample_rate_hz or None, channel=ref.channel
    )
    lo = int(round(ref.start_s * fs))
    hi = len(x) if not ref.stop_s else int(round(ref.stop_s * fs))
    if hi > len(x) or lo >= hi:
        raise InputFileError(
            f"template {path}: excerpt [{ref.start_s:g}, {ref.stop_s:g}] s lies outside its {len(x) / fs:g} s"
        )
    x = x[lo:hi] - np.mean(x[lo:hi])
    if not np.any(x):
        raise InputFileError(f"template {path}: the excerpt is silent")
    if not (ref.f_low_hz and ref.f_high_hz):
        spectrum = np.abs(np.fft.rfft(x)) ** 2
        freq = np.fft.rfftfreq(len(x), 1 / fs)
        cum = np.cumsum(spectrum) / np.sum(spectrum)
        f_lo = float(freq[np.searchsorted(cum, 0.005)])
        f_hi = float(freq[min(np.searchsorted(cum, 0.995), len(freq) - 1)])
        ref = dataclasses.replace(ref, f_low_hz=max(f_lo, 1.0), f_high_hz=max(f_hi, f_lo + 2.0))
    if ref.f_high_hz >= fs / 2:
        raise ConfigError("f_high_hz", f"template band reaches {ref.f_high_hz:g} Hz, above its Nyquist {fs / 2:g} Hz")
    analytic = scipy.signal.hilbert(x)
    t = np.arange(len(x)) / fs
    b = analytic * np.exp(-2j * np.pi * ref.centre_hz * t)
    table = scipy.signal.resample_poly(b, _TABLE_OVERSAMPLING, 1)[: (len(x) - 1) * _TABLE_OVERSAMPLING + 1]
    return table, fs * _TABLE_OVERSAMPLING, dataclasses.replace(ref, duration_s=(len(x) - 1) / fs)


def reference_replica(ref: ReferenceWaveform, *, base_dir: str | Path | None = None) -> Replica:
    """The :class:`Replica` of a reference (templates are read from their file here).

    Raises
    ------
    InputFileError, ConfigError
        A template whose file, variable or excerpt is unusable.
    """
    if ref.kind in ("lfm", "hfm"):
        return Replica(ref)
    if ref.kind == "pn":
        table, rate = _pn_table(ref)
        return Replica(ref, table, rate)
    table, rate, filled = _template_table(ref, None if base_dir is None else Path(base_dir))
    return Replica(filled, table, rate)


def reference_waveform(replica: Replica, fs: float) -> np.ndarray:
    """Real passband samples Re[s_a(n/fs)] of one emission, n = 0 … (duration·fs), unit peak.

    Raises
    ------
    ConfigError
        When the band reaches fs/2.
    """
    ref = replica.reference
    if ref.f_high_hz >= fs / 2:
        raise ConfigError(
            "sample_rate_hz", f"{fs:g} Hz cannot hold the reference's band up to {ref.f_high_hz:g} Hz (Nyquist {fs / 2:g} Hz)"
        )
    t = np.arange(int(math.floor(replica.duration_s * fs)) + 1) / fs
    x = np.real(replica.envelope(t) * np.exp(2j * np.pi * replica.centre_hz * t))
    return x / np.max(np.abs(x))


@dataclass(frozen=True)
class ReferenceBound:
    """Cramér–Rao bounds of a reference's arrival time and Doppler scale at E/N0 = 1 (scale by 1/√(E/N0)).

    Attributes
    ----------
    sigma_t_s : float
        Arrival time (of the reference's first sample), Doppler jointly unknown [s·√(E/N0)].
    sigma_eps : float
        Doppler scale ε, arrival time jointly unknown [√(E/N0)].
    sigma_t_known_eps_s : float
        Arrival time when ε is known (e.g. from a pre/postamble pair) [s·√(E/N0)].
    ridge_slope_s : float
        g = (J_rr⁻¹ J_rε)_t [s], r = (t_a, θ, A): the likelihood's delay–Doppler ridge, along which
        t_a + g·ε stays fixed (an error Δε moves the arrival estimate by −g·Δε;
        for an HFM g ≈ −1/k, :func:`hfm_coupling_s`).
    """

    sigma_t_s: float
    sigma_eps: float
    sigma_t_known_eps_s: float
    ridge_slope_s: float

    def at(self, e_n0: float) -> tuple[float, float, float]:
        """(σ_t, σ_ε, σ_t|ε) at E/N0 (linear, E the received energy, N0 the one-sided noise PSD)."""
        k = 1.0 / math.sqrt(max(e_n0, 1e-30))
        return self.sigma_t_s * k, self.sigma_eps * k, self.sigma_t_known_eps_s * k


def reference_crlb(replica: Replica) -> ReferenceBound:
    """Joint CRLB of arrival time and Doppler scale for r(t) = A Re[e^{jθ} s_a((1+ε)(t − t_a))] + w.

    Amplitude A and phase θ unknown; white noise of one-sided PSD N0.

    Notes
    -----
    Fisher information J_ij = (2/N0) ∫ ∂_i s ∂_j s dt = (1/N0) Re ∫ D_i D_j* dt
    for analytic derivatives D (the ∫ D_i D_j term of a positive-frequency
    signal vanishes), with E = ½∫|s_a|² dt:
    D_t = −s_a'(t), D_ε = t s_a'(t), D_θ = j s_a, D_A = s_a at ε = 0, t_a = 0.
    The delay-only, phase-unknown entry reduces to SPEC §6's
    σ_τ = 1/(2π β √(2E/N0)), β the RMS bandwidth about the band's centroid.
    """
    n = 20001
    t = np.linspace(0, replica.duration_s, n)
    dt = t[1] - t[0]
    b = replica.envelope(t)
    db = replica.derivative(t)
    ds = db + 2j * np.pi * replica.centre_hz * b  # s_a' e^{−j2π f_c t}: the common carrier cancels in Re ∫ D_i D_j*
    cols = np.stack([-ds, t * ds, 1j * b, b])
    gram = np.real(cols @ np.conj(cols).T) * dt
    energy = 0.5 * np.sum(np.abs(b) ** 2) * dt
    fisher = gram / energy  # J at E/N0 = 1 (then N0 = E)
    cov = np.linalg.inv(fisher)
    rest = [0, 2, 3]  # t_a, θ, A: what the likelihood re-optimises for a given ε
    known = np.linalg.inv(fisher[np.ix_(rest, rest)])
    return ReferenceBound(
        sigma_t_s=float(math.sqrt(cov[0, 0])),
        sigma_eps=float(math.sqrt(cov[1, 1])),
        sigma_t_known_eps_s=float(math.sqrt(known[0, 0])),
        ridge_slope_s=float(np.linalg.solve(fisher[np.ix_(rest, rest)], fisher[rest, 1])[0]),
    )


_COMPACT_HELP = (
    "lfm:F1-F2:DURATION, hfm:F1-F2:DURATION, pn:CARRIER:CHIPRATE:DEGREE, template:FILE[:START-STOP] "
    "(Hz, s), or a TOML/JSON file"
)


def _numbers(text: str, spec: str, count: int) -> list[float]:
    try:
        values = [float(v) for v in text.replace("-", " ").split()]
    except ValueError:
        values = []
    if len(values) != count:
        raise ConfigError("reference", f"cannot read {spec!r}: expected {_COMPACT_HELP}")
    return values


def parse_reference(spec: str, **overrides) -> ReferenceWaveform:
    """A reference from its compact form (``lfm:19000-29000:0.05``), with keyword overrides."""
    kind, _, rest = spec.partition(":")
    kind = kind.strip().lower()
    parts = rest.split(":") if rest else []
    fields: dict[str, Any] = {"kind": kind}
    if kind in ("lfm", "hfm") and len(parts) in (2, 3):
        fields["f_low_hz"], fields["f_high_hz"] = _numbers(parts[0], spec, 2)
        (fields["duration_s"],) = _numbers(parts[1], spec, 1)
        if len(parts) == 3:
            fields["window"] = parts[2]
        if fields["f_low_hz"] > fields["f_high_hz"]:
            fields["f_low_hz"], fields["f_high_hz"], fields["down"] = fields["f_high_hz"], fields["f_low_hz"], True
    elif kind == "pn" and len(parts) == 3:
        fields["carrier_hz"], fields["chip_rate_hz"] = _numbers(f"{parts[0]} {parts[1]}", spec, 2)
        (degree,) = _numbers(parts[2], spec, 1)
        fields["degree"] = int(degree)
    elif kind == "template" and len(parts) in (1, 2):
        fields["file"] = parts[0]
        if len(parts) == 2:
            fields["start_s"], fields["stop_s"] = _numbers(parts[1], spec, 2)
    else:
        raise ConfigError("reference", f"cannot read {spec!r}: expected {_COMPACT_HELP}")
    fields.update({k: v for k, v in overrides.items() if v not in (None, "")})
    return ReferenceWaveform.from_dict(fields)


@lru_cache(maxsize=None)
def _toml():
    import tomllib

    return tomllib


def load_references(spec: str) -> list[ReferenceWaveform]:
    """References from a TOML/JSON file (one table, or ``[[reference]]`` tables) or a compact string.

    Raises
    ------
    ConfigError, InputFileError
        An unreadable file, an unknown key, an invalid value.
    """
    path = Path(spec)
    if path.suffix.lower() in (".toml", ".json"):
        if not path.is_file():
            raise InputFileError(f"reference file not found: {path}")
        try:
            text = path.read_text(encoding="utf-8")
            data = json.loads(text) if path.suffix.lower() == ".json" else _toml().loads(text)
        except (ValueError, UnicodeDecodeError) as exc:
            raise InputFileError(f"reference file {path} is not valid {path.suffix[1:].upper()}: {exc}") from None
        if isinstance(data, dict) and data.get("format") == REFERENCE_SIDECAR_FORMAT:
            data = data.get("references", [])
        tables = data.get("reference", data) if isinstance(data, dict) else data
        tables = tables if isinstance(tables, list) else [tables]
        refs = []
        for table in tables:
            if not isinstance(table, dict):
                raise InputFileError(f"reference file {path}: each reference must be a table of parameters")
            try:
                ref = ReferenceWaveform.from_dict(table)
            except ConfigError as exc:
                raise exc.in_file(f"reference file {path}") from None
            except (TypeError, ValueError, OverflowError) as exc:  # a value of a type no check expected
                raise ConfigError("reference", f"a value is of the wrong type ({exc})",
                                  file=f"reference file {path}") from None
            if ref.kind == "template" and not Path(ref.file).is_absolute():
                ref = dataclasses.replace(ref, file=str(path.parent / ref.file))
            refs.append(ref)
        return refs
    return [parse_reference(spec)]


#: format of the sidecar written beside a reference beacon's WAV
REFERENCE_SIDECAR_FORMAT = "seamodem.reference-sidecar/1"


def emission_times(references: list[ReferenceWaveform], *, count: int, period_s: float, start_s: float) -> list[dict]:
    """Every emission of a beacon schedule: reference i of n at start + k·period + i·period/n, then the rest
    of its packet (:meth:`ReferenceWaveform.packet`: train, postamble).

    Returns
    -------
    list of dict
        ``frame_index``, ``t_emit_s``, ``reference`` (name), ``role`` ("ping", "preamble", "postamble"),
        ``train_position`` (the chirp's place in its train), sorted by time.
    """
    out = []
    n = len(references)
    for k in range(count):
        for i, ref in enumerate(references):
            t = start_s + k * period_s + i * period_s / n
            for offset, role, position in ref.packet():
                out.append({"frame_index": k, "t_emit_s": t + offset, "reference": ref.name, "role": role,
                            "train_position": position})
    return sorted(out, key=lambda e: e["t_emit_s"])


def write_reference_beacon(
    path: str | Path,
    replicas: list[Replica],
    *,
    count: int,
    period_s: float,
    start_s: float = 0.0,
    fs: float,
    subtype: str = "FLOAT",
    peak: float = 0.5,
    command: str = "",
) -> dict[str, Any]:
    """Write a beacon schedule of reference pings to a WAV and its sidecar (``.json``); returns the sidecar.

    Emissions as :func:`emission_times`; each ping has unit peak before the
    file's scaling to ``peak`` of full scale. The two files appear together or
    not at all.

    Raises
    ------
    ConfigError
        Bad schedule, overlapping emissions, a band above fs/2.
    """
    from .. import __version__
    from ..io.files import atomic_outputs
    from ..io.sidecar import write_json
    from ..io.wav import write_wav_blocks

    if not (isinstance(count, int) and count >= 1):
        raise ConfigError("count", f"must be an integer >= 1, got {count!r}")
    if not (math.isfinite(period_s) and period_s > 0):
        raise ConfigError("period", f"must be > 0 s, got {period_s!r}")
    if not (math.isfinite(start_s) and start_s >= 0):
        raise ConfigError("start", f"must be >= 0 s, got {start_s!r}")
    if not 0 < peak <= 1:
        raise ConfigError("peak", f"must be in (0, 1], got {peak!r}")
    refs = [rep.reference for rep in replicas]
    waves = {rep.reference.name: reference_waveform(rep, fs) for rep in replicas}
    emissions = emission_times(refs, count=count, period_s=period_s, start_s=start_s)
    for a, b in zip(emissions, emissions[1:]):
        if a["t_emit_s"] + len(waves[a["reference"]]) / fs > b["t_emit_s"]:
            raise ConfigError(
                "period", f"emissions overlap: {a['reference']} at {a['t_emit_s']:g} s runs past {b['t_emit_s']:g} s"
            )
    n_total = int(math.ceil((emissions[-1]["t_emit_s"] + replicas[0].duration_s) * fs)) + int(0.1 * fs)
    n_total = max(n_total, int(math.ceil((start_s + count * period_s) * fs)))
    starts = [(int(round(e["t_emit_s"] * fs)), waves[e["reference"]]) for e in emissions]
    for e, (i0, _) in zip(emissions, starts):
        e["t_emit_s"] = i0 / fs  # emissions start on a sample: the sidecar states the exact time

    def blocks(size=1 << 18):
        for lo in range(0, n_total, size):
            hi = min(n_total, lo + size)
            out = np.zeros(hi - lo)
            for i0, w in starts:
                a, b = max(lo, i0), min(hi, i0 + len(w))
                if a < b:
                    out[a - lo : b - lo] += w[a - i0 : b - i0]
            yield peak * out

    path = Path(path)
    sidecar = {
        "format": REFERENCE_SIDECAR_FORMAT,
        "created_by": f"seamodem {__version__}",
        "command": command,
        "references": [r.to_dict() for r in refs],
        "schedule": {"count": count, "period_s": period_s, "start_s": start_s},
        "recording": {"file": path.name, "sample_rate_hz": fs, "n_samples": n_total, "duration_s": n_total / fs,
                      "subtype": subtype, "scale": peak},
        "frames": emissions,
    }
    with atomic_outputs(path, path.with_suffix(".json")) as (tmp_wav, tmp_json):
        write_wav_blocks(tmp_wav, blocks(), fs=int(round(fs)), subtype=subtype)
        write_json(tmp_json, sidecar)
    return sidecar
