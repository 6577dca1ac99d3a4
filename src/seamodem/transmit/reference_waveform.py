"""The description of a reference waveform and where it comes from: TOML/JSON files, compact specs, packets.

A :class:`ReferenceWaveform` is a frozen, validated configuration (JSON/TOML
round trip) of an LFM or HFM chirp, an m-sequence ping or a template excerpt,
with the packet it is emitted in (preamble train, postamble). Its replica and
bounds are in :mod:`.replica`, the beacon that emits it in
:mod:`.reference_beacon`; :mod:`.reference` gathers the three.
"""

from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any

from ..errors import ConfigError, InputFileError, value_text

__all__ = [
    "REFERENCE_KINDS",
    "WINDOWS",
    "PN_SPAN",
    "REFERENCE_SIDECAR_FORMAT",
    "ReferenceWaveform",
    "parse_reference",
    "load_references",
]

REFERENCE_KINDS = ("lfm", "hfm", "pn", "template")
WINDOWS = ("tukey", "hann", "rect")

#: PN chips' SRRC span [chips]; the ping lasts (2^m − 1 + span)/R
PN_SPAN = 8

#: format of the sidecar written beside a reference beacon's WAV
REFERENCE_SIDECAR_FORMAT = "seamodem.reference-sidecar/1"


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
            object.__setattr__(self, "duration_s", (2**self.degree - 1 + PN_SPAN) / self.chip_rate_hz)
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

        Returns
        -------
        list of (float, str, int)
            One tuple per chirp, in emission order.
        """
        n_post = (self.postamble_count or self.train_count) if self.postamble_s else 0
        if self.train_count == 1 and not n_post:
            return [(0.0, "ping", 0)]
        out = [(i * self.train_spacing_s, "preamble", i) for i in range(self.train_count)]
        out += [(self.postamble_s + i * self.train_spacing_s, "postamble", i) for i in range(n_post)]
        return out

    def default_name(self) -> str:
        """The label used when ``name`` is not given.

        Returns
        -------
        str
            ``pn<degree>_<carrier>k``, the template file's stem, or ``<kind>_<f1>-<f2>k_<duration>ms``.
        """
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
        """Only the fields that matter for this kind, plus ``kind`` and ``name``.

        Returns
        -------
        dict
            The fields (packet fields only when not at their defaults).
        """
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
        """Inverse of :meth:`to_dict`; unknown keys are an error naming them.

        Parameters
        ----------
        data : dict
            Field names and values; ``kind`` is required.

        Returns
        -------
        ReferenceWaveform
            The validated reference.

        Raises
        ------
        ConfigError
            An unknown key, a missing ``kind``, an invalid value.
        """
        names = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(data) - names)
        if unknown:
            raise ConfigError(unknown[0], f"is not a reference parameter (known: {', '.join(sorted(names))})")
        if "kind" not in data:
            raise ConfigError("kind", "missing: say which waveform (lfm, hfm, pn or template)")
        return cls(**data)


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
    """A reference from its compact form (``lfm:19000-29000:0.05``), with keyword overrides.

    Parameters
    ----------
    spec : str
        ``lfm:F1-F2:DURATION[:WINDOW]``, ``hfm:…``, ``pn:CARRIER:CHIPRATE:DEGREE`` or
        ``template:FILE[:START-STOP]`` (Hz, s); F1 > F2 is a down-sweep.
    **overrides
        :class:`ReferenceWaveform` fields; ``None`` and ``""`` are ignored.

    Returns
    -------
    ReferenceWaveform
        The validated reference.

    Raises
    ------
    ConfigError
        A spec that cannot be read, an invalid value.
    """
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

    Parameters
    ----------
    spec : str
        A ``.toml`` or ``.json`` file (a reference beacon's sidecar too), else a compact spec
        (:func:`parse_reference`). A template's relative file is relative to the reference file.

    Returns
    -------
    list of ReferenceWaveform
        The references, in file order.

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
