"""Frame configuration: one frozen, validated record of everything a frame needs.

The configuration round-trips through JSON and TOML and comes in named presets
taken from the source papers (SPEC §2). Values the papers do not give are
chosen here and marked *chosen* in :data:`PRESET_NOTES`.
"""

from __future__ import annotations

import dataclasses
import json
import math
import tomllib
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

from .errors import ConfigError, InputFileError

__all__ = [
    "FrameConfig",
    "PRESETS",
    "PRESET_NOTES",
    "get_preset",
    "load_config",
    "save_config",
    "config_text",
    "config_to_toml",
]

MODULATIONS = {"bpsk": 1, "qpsk": 2, "8psk": 3}
FEC_SCHEMES = ("conv_k7_r12", "none")
CRC_SCHEMES = {"crc16": 2, "crc32": 4}
#: Bytes of the length header that precedes the payload inside the coded block.
LENGTH_HEADER_BYTES = 2
#: text a beacon sends in every frame when given none; {index} becomes the frame index
DEFAULT_PAYLOAD_TEXT = "seamodem frame {index}"
#: Tail bits that terminate the K = 7 convolutional code in the all-zero state.
CONV_TAIL_BITS = 6


@dataclass(frozen=True, kw_only=True)
class FrameConfig:
    """Everything needed to build (and later to receive) one frame, SPEC §2.

    Parameters
    ----------
    name : str
        Free label, e.g. the preset's name.
    sample_rate_hz : float
        Sample rate fs [Hz]. Need not be a multiple of the symbol rate.
    carrier_hz : float
        Data carrier f0 [Hz].
    symbol_rate_hz : float
        Symbol rate 1/T [Bd].
    rolloff : float
        SRRC roll-off α, in [0, 1].
    srrc_span_symbols : int
        Total length of the truncated SRRC pulse in symbols (even); the pulse
        spans ±span/2 symbols and must fit in the guard, span/2 ≤ n_guard.
    modulation : {"bpsk", "qpsk", "8psk"}
        Gray-mapped PSK of the data symbols. Pilots are always BPSK.
    n_guard, n_pilot, n_data : int
        Null symbols at each end (Ng), pilot symbols (Np), data symbols (Nd).
    tone_hz : float
        Pure-tone frequency f_pt [Hz]; outside the data band by at least
        ``tone_guard_hz`` and below fs/2.
    tone_power_share : float
        Tone power / (tone + data power), in [0, 1). 0.5 gives equal powers,
        the assumption behind SPEC §6's tone CRLB figure.
    tone_guard_hz : float
        Minimum distance between the tone and the data band edge [Hz].
    tone_ramp_s : float
        Raised-cosine ramp at each end of the tone [s]; 0 for a rectangular tone.
    pilot_seed : int
        Seed of the deterministic pilot search (see :func:`seamodem.pilot_bits`).
    fec : {"conv_k7_r12", "none"}
        Forward error correction: the K = 7, rate 1/2 (133, 171) convolutional
        code with a block interleaver, or none (for uncoded BER work).
    crc : {"crc16", "crc32"}
        Frame check over the length header and payload.
    """

    name: str = "custom"
    sample_rate_hz: float
    carrier_hz: float
    symbol_rate_hz: float
    rolloff: float
    srrc_span_symbols: int = 32
    modulation: str = "bpsk"
    n_guard: int
    n_pilot: int
    n_data: int
    tone_hz: float
    tone_power_share: float = 0.5
    tone_guard_hz: float = 500.0
    tone_ramp_s: float = 0.001
    pilot_seed: int = 1
    fec: str = "conv_k7_r12"
    crc: str = "crc16"

    def __post_init__(self):
        for f in fields(self):
            value = getattr(self, f.name)
            if f.type == "float":
                if isinstance(value, bool) or not isinstance(value, (int, float)):
                    raise ConfigError(f.name, f"must be a number, got {value!r}")
                if not math.isfinite(value):
                    raise ConfigError(f.name, f"must be finite, got {value!r}")
                object.__setattr__(self, f.name, float(value))
            elif f.type == "int":
                if isinstance(value, bool) or not (
                    isinstance(value, int) or (isinstance(value, float) and value.is_integer())
                ):
                    raise ConfigError(f.name, f"must be an integer, got {value!r}")
                object.__setattr__(self, f.name, int(value))
            elif f.type == "str" and not isinstance(value, str):
                raise ConfigError(f.name, f"must be a string, got {value!r}")
        self._validate()

    def _validate(self):
        fs = self.sample_rate_hz
        nyq = fs / 2
        if fs <= 0:
            raise ConfigError("sample_rate_hz", f"must be > 0, got {fs!r}")
        if self.symbol_rate_hz <= 0:
            raise ConfigError("symbol_rate_hz", f"must be > 0, got {self.symbol_rate_hz!r}")
        if not 0.0 <= self.rolloff <= 1.0:
            raise ConfigError("rolloff", f"must be in [0, 1], got {self.rolloff!r}")
        if self.modulation not in MODULATIONS:
            raise ConfigError("modulation", f"must be one of {sorted(MODULATIONS)}, got {self.modulation!r}")
        if self.fec not in FEC_SCHEMES:
            raise ConfigError("fec", f"must be one of {list(FEC_SCHEMES)}, got {self.fec!r}")
        if self.crc not in CRC_SCHEMES:
            raise ConfigError("crc", f"must be one of {sorted(CRC_SCHEMES)}, got {self.crc!r}")
        lo, hi = self.data_band_hz
        if self.carrier_hz <= 0 or self.carrier_hz >= nyq:
            raise ConfigError("carrier_hz", f"must be in (0, fs/2 = {nyq:g}) Hz, got {self.carrier_hz!r}")
        if lo <= 0 or hi >= nyq:
            raise ConfigError(
                "carrier_hz",
                f"data band [{lo:g}, {hi:g}] Hz (carrier ± (1 + rolloff)·symbol_rate/2) "
                f"must lie inside (0, fs/2 = {nyq:g}) Hz",
            )
        if self.tone_hz <= 0 or self.tone_hz >= nyq:
            raise ConfigError("tone_hz", f"must be in (0, fs/2 = {nyq:g}) Hz, got {self.tone_hz!r}")
        if self.tone_guard_hz < 0:
            raise ConfigError("tone_guard_hz", f"must be >= 0, got {self.tone_guard_hz!r}")
        if lo - self.tone_guard_hz < self.tone_hz < hi + self.tone_guard_hz:
            raise ConfigError(
                "tone_hz",
                f"{self.tone_hz:g} Hz lies inside the data band [{lo:g}, {hi:g}] Hz "
                f"widened by tone_guard_hz = {self.tone_guard_hz:g} Hz",
            )
        if not 0.0 <= self.tone_power_share < 1.0:
            raise ConfigError("tone_power_share", f"must be in [0, 1), got {self.tone_power_share!r}")
        if self.n_guard < 0:
            raise ConfigError("n_guard", f"must be >= 0, got {self.n_guard!r}")
        if self.n_pilot < 8:
            raise ConfigError("n_pilot", f"must be >= 8, got {self.n_pilot!r}")
        if self.n_data < 1:
            raise ConfigError("n_data", f"must be >= 1, got {self.n_data!r}")
        span = self.srrc_span_symbols
        if span < 2 or span % 2:
            raise ConfigError("srrc_span_symbols", f"must be an even integer >= 2, got {span!r}")
        if span // 2 > self.n_guard:
            raise ConfigError(
                "srrc_span_symbols",
                f"half the span ({span // 2} symbols) must fit in the guard n_guard = {self.n_guard}",
            )
        if self.tone_ramp_s < 0 or 2 * self.tone_ramp_s > self.frame_duration_s:
            raise ConfigError(
                "tone_ramp_s",
                f"must be in [0, frame_duration/2 = {self.frame_duration_s / 2:g}] s, got {self.tone_ramp_s!r}",
            )
        if self.pilot_seed < 0:
            raise ConfigError("pilot_seed", f"must be >= 0, got {self.pilot_seed!r}")
        if self.capacity_bytes < 1:
            raise ConfigError(
                "n_data",
                f"{self.n_data} data symbols carry no payload byte after header, CRC and coding",
            )

    # Derived quantities -------------------------------------------------
    @property
    def symbol_period_s(self) -> float:
        """Symbol duration T [s]."""
        return 1.0 / self.symbol_rate_hz

    @property
    def bandwidth_hz(self) -> float:
        """Occupied data bandwidth B = (1 + α)/T [Hz]."""
        return (1.0 + self.rolloff) * self.symbol_rate_hz

    @property
    def data_band_hz(self) -> tuple[float, float]:
        """Data band [f0 − B/2, f0 + B/2] [Hz]."""
        half = self.bandwidth_hz / 2
        return (self.carrier_hz - half, self.carrier_hz + half)

    @property
    def samples_per_symbol(self) -> float:
        """fs·T, not necessarily an integer (15.02 for jmse2024)."""
        return self.sample_rate_hz / self.symbol_rate_hz

    @property
    def bits_per_symbol(self) -> int:
        return MODULATIONS[self.modulation]

    @property
    def n_symbols(self) -> int:
        """Symbols of the whole frame, guards included: 2·Ng + Np + Nd."""
        return 2 * self.n_guard + self.n_pilot + self.n_data

    @property
    def frame_duration_s(self) -> float:
        """T_F = (2·Ng + Np + Nd)·T [s]."""
        return self.n_symbols * self.symbol_period_s

    @property
    def pilot_start_s(self) -> float:
        """Time of the first pilot symbol's peak after the frame start, Ng·T [s]."""
        return self.n_guard * self.symbol_period_s

    @property
    def n_coded_bits(self) -> int:
        """Coded bits carried by the data symbols, Nd·log2(M)."""
        return self.n_data * self.bits_per_symbol

    @property
    def n_info_bits(self) -> int:
        """Information bits of the coded block (header + payload + CRC)."""
        if self.fec == "none":
            return self.n_coded_bits
        return self.n_coded_bits // 2 - CONV_TAIL_BITS

    @property
    def capacity_bytes(self) -> int:
        """Largest payload one frame carries [bytes]."""
        return self.n_info_bits // 8 - LENGTH_HEADER_BYTES - CRC_SCHEMES[self.crc]

    # Round trip ---------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, data: dict[str, Any], *, base: "FrameConfig | None" = None) -> "FrameConfig":
        """Build a configuration from a mapping, optionally on top of ``base``.

        Raises
        ------
        ConfigError
            For an unknown key, a missing required key, or an invalid value.
        """
        known = {f.name for f in fields(cls)}
        for key in data:
            if key not in known:
                raise ConfigError(key, f"unknown configuration parameter (known: {', '.join(sorted(known))})")
        merged = base.to_dict() if base is not None else {}
        merged.update(data)
        missing = [
            f.name
            for f in fields(cls)
            if f.name not in merged
            and f.default is dataclasses.MISSING
            and f.default_factory is dataclasses.MISSING
        ]
        if missing:
            raise ConfigError(missing[0], "missing (required when no preset is given)")
        return cls(**merged)

    def replace(self, **changes) -> "FrameConfig":
        return dataclasses.replace(self, **changes)

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), indent=2)

    def to_toml(self) -> str:
        return config_to_toml(self.to_dict())


def _toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)
    raise TypeError(f"cannot write {type(value).__name__} to TOML")


def config_to_toml(data: dict[str, Any]) -> str:
    """Write a flat mapping of scalars as TOML (enough for a frame configuration)."""
    return "".join(f"{key} = {_toml_value(value)}\n" for key, value in data.items())


# Presets ---------------------------------------------------------------------

PRESETS: dict[str, FrameConfig] = {
    # Paper 000 Table 5 (the sea trial of paper 002): fs, f0, 1/T, B = 8.96 kHz
    # (α = 0.4), f_pt, T_F = 300 ms. Chosen: 32 guard symbols (5 ms) at each end,
    # 150 pilots (the pilot count of paper 003), the rest data so that
    # 2·32 + 150 + 1706 = 1920 symbols = 300 ms; BPSK (paper 002 §II.A);
    # SRRC span 32 symbols; equal tone and data powers.
    "jmse2024": FrameConfig(
        name="jmse2024",
        sample_rate_hz=96153.0,
        carrier_hz=28000.0,
        symbol_rate_hz=6400.0,
        rolloff=0.4,
        srrc_span_symbols=32,
        modulation="bpsk",
        n_guard=32,
        n_pilot=150,
        n_data=1706,
        tone_hz=20000.0,
    ),
    # Paper 003 §II.A: f0 = 23 kHz in 17–30 kHz, f_pt = 11 kHz, 150 pilots +
    # 2518 BPSK data symbols. Chosen: fs = 96 kHz, 8 kBd, α = 0.5 so the band is
    # 17–29 kHz (B = 12 kHz); 32 guard symbols; SRRC span 32 symbols.
    "oceans2021": FrameConfig(
        name="oceans2021",
        sample_rate_hz=96000.0,
        carrier_hz=23000.0,
        symbol_rate_hz=8000.0,
        rolloff=0.5,
        srrc_span_symbols=32,
        modulation="bpsk",
        n_guard=32,
        n_pilot=150,
        n_data=2518,
        tone_hz=11000.0,
    ),
}

PRESET_NOTES: dict[str, str] = {
    "jmse2024": (
        "paper 000 Table 5: fs 96 153 Hz, f0 28 kHz, 6.4 kBd, B 8.96 kHz (α 0.4), f_pt 20 kHz, T_F 300 ms. "
        "Chosen: Ng 32, Np 150, Nd 1706 (1920 symbols = 300 ms), BPSK, SRRC span 32, tone share 0.5, "
        "K7 r1/2 code + CRC-16."
    ),
    "oceans2021": (
        "paper 003 §II.A: f0 23 kHz, band 17–30 kHz, f_pt 11 kHz, Np 150, Nd 2518 BPSK. "
        "Chosen: fs 96 kHz, 8 kBd, α 0.5 (band 17–29 kHz), Ng 32, SRRC span 32, tone share 0.5, "
        "K7 r1/2 code + CRC-16."
    ),
}


def get_preset(name: str) -> FrameConfig:
    """Return the named preset.

    Parameters
    ----------
    name : str
        A key of ``PRESETS`` (e.g. ``"oceans2021"``).

    Returns
    -------
    FrameConfig
        The preset's frame configuration.

    Raises
    ------
    ConfigError
        If no preset has that name.
    """
    try:
        return PRESETS[name]
    except KeyError:
        raise ConfigError("preset", f"unknown preset {name!r}; choose from {', '.join(PRESETS)}") from None


def _read_mapping(path: Path) -> dict[str, Any]:
    if not path.is_file():
        raise InputFileError(f"config file not found: {path}")
    text = path.read_text(encoding="utf-8")
    try:
        if path.suffix.lower() == ".toml":
            data = tomllib.loads(text)
        else:
            data = json.loads(text)
    except (tomllib.TOMLDecodeError, json.JSONDecodeError) as exc:
        raise InputFileError(f"config file {path} is not valid {path.suffix.lstrip('.').upper() or 'JSON'}: {exc}") from None
    if not isinstance(data, dict):
        raise InputFileError(f"config file {path} must hold a table of parameters")
    # A sidecar written by `seamodem tx` holds the configuration under "config".
    if "config" in data and isinstance(data["config"], dict):
        data = data["config"]
    return data


def load_config(path: str | Path, *, base: FrameConfig | None = None) -> FrameConfig:
    """Read a configuration from a TOML or JSON file (or a sidecar), over ``base``.

    Parameters
    ----------
    path : str or Path
        A ``.toml`` file, or JSON (any other suffix); a ``seamodem tx``
        sidecar is read from its ``config`` table.
    base : FrameConfig or None, optional
        Values for the keys the file leaves out (e.g. a preset); None
        requires every parameter without a default.

    Returns
    -------
    FrameConfig
        The validated configuration.

    Raises
    ------
    InputFileError
        Missing file, invalid TOML/JSON, or not a table.
    ConfigError
        Unknown or missing key, or an invalid value.
    """
    return FrameConfig.from_dict(_read_mapping(Path(path)), base=base)


def config_text(config: FrameConfig, suffix: str) -> str:
    """The configuration as TOML for a ``.toml`` suffix, else as JSON."""
    return config.to_toml() if suffix.lower() == ".toml" else config.to_json() + "\n"


def save_config(config: FrameConfig, path: str | Path) -> None:
    """Write a configuration as TOML (``.toml``) or JSON (any other suffix).

    Parameters
    ----------
    config : FrameConfig
        The configuration.
    path : str or Path
        Output file, overwritten; its suffix chooses the format.
    """
    path = Path(path)
    path.write_text(config_text(config, path.suffix), encoding="utf-8")
