"""JANUS parameter sets: centre frequency, band and chip length, and the numbers derived from them.

Parameter set 1 (fc 11 520 Hz, 4 160 Hz available, the "9-14 kHz band") is the default of the
standard and of its reference implementation. Others are built from any fc and band whose
frequency-slot count B / (2·cf) is prime (the hopping pattern counts in GF(Q)).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

__all__ = ["JanusParameterSet", "PARAMETER_SETS", "get_parameter_set", "primitive_root"]


def primitive_root(q: int) -> int:
    """Smallest primitive element of GF(q), q prime.

    Parameters
    ----------
    q : int
        A prime.

    Returns
    -------
    int
        The smallest g in [2, q) whose powers run through every non-zero element.
    """
    if q < 3 or any(q % d == 0 for d in range(2, int(q**0.5) + 1)):
        raise ValueError(f"the slot count must be a prime ≥ 3, got {q}")
    for g in range(2, q):
        if len({pow(g, k, q) for k in range(1, q)}) == q - 1:
            return g
    raise AssertionError("unreachable: every prime field has a primitive element")


@dataclass(frozen=True, kw_only=True)
class JanusParameterSet:
    """One JANUS parameter set.

    Parameters
    ----------
    pset_id : int
        Identifier (1 is the standard's default).
    name : str
        Human-readable name.
    fc_hz : float
        Centre frequency [Hz].
    bandwidth_hz : float
        Available bandwidth B [Hz]; the tone spacing is round(B / 26).
    chip_len_exp : int
        Chip-length exponent e: a chip lasts 2**e / cf.
    """

    pset_id: int = 1
    name: str = "Initial JANUS band (9-14 kHz)"
    fc_hz: float = 11520.0
    bandwidth_hz: float = 4160.0
    chip_len_exp: int = 0

    def __post_init__(self):
        if not 0 <= self.chip_len_exp <= 8:
            raise ValueError(f"chip_len_exp must be in [0, 8], got {self.chip_len_exp!r}")
        if self.bandwidth_hz <= 0 or self.fc_hz <= 0:
            raise ValueError(f"fc_hz and bandwidth_hz must be > 0, got {self.fc_hz!r}, {self.bandwidth_hz!r}")
        if self.fc_hz - self.bandwidth_hz / 2 <= 0:
            raise ValueError(f"the band must lie above 0 Hz: fc_hz {self.fc_hz} − bandwidth_hz/2 ≤ 0")
        primitive_root(self.n_slots)

    @property
    def chip_hz(self) -> float:
        """Tone spacing cf = round(B / 26) [Hz] (13 slots × 2 tones in the band)."""
        return float(round(self.bandwidth_hz / 26))

    @property
    def chip_s(self) -> float:
        """Chip duration Tc = 2**e / cf [s]."""
        return 2.0**self.chip_len_exp / self.chip_hz

    @property
    def n_slots(self) -> int:
        """Frequency slots Q = B / (2·cf) (13 for every standard set)."""
        return int(round(self.bandwidth_hz / (2 * self.chip_hz)))

    @property
    def alpha(self) -> int:
        """Primitive element of GF(Q) used by the hopping pattern (2 for Q = 13)."""
        return primitive_root(self.n_slots)

    @property
    def used_band_hz(self) -> float:
        """U = (Q − 1)·2·cf [Hz]: the wake-up tones sit at −U/2, 0, +U/2 about fc."""
        return (self.n_slots - 1) * 2 * self.chip_hz

    @property
    def f_low_hz(self) -> float:
        """Lowest tone [Hz]."""
        return self.fc_hz + self.tone_offsets_hz()[0]

    @property
    def f_high_hz(self) -> float:
        """Highest tone [Hz]."""
        return self.fc_hz + self.tone_offsets_hz()[-1]

    def tone_offsets_hz(self) -> list[int]:
        """Baseband offset of tone k = 2·slot + bit, cast to whole Hz as the reference does."""
        q = self.n_slots
        return [int(self.chip_hz * (k - q)) for k in range(2 * q)]

    def check_rate(self, fs: float) -> None:
        """Raise ValueError unless ``fs`` holds the band (highest tone and half a spacing below fs/2)."""
        if fs <= 2 * (self.f_high_hz + self.chip_hz):
            raise ValueError(
                f"fs must exceed 2·(highest tone + spacing) = {2 * (self.f_high_hz + self.chip_hz):g} Hz "
                f"for parameter set {self.pset_id}, got {fs!r}"
            )

    def to_dict(self) -> dict:
        """The set's fields (JSON-ready)."""
        return asdict(self)


#: The parameter sets this package knows by number.
PARAMETER_SETS: dict[int, JanusParameterSet] = {1: JanusParameterSet()}


def get_parameter_set(pset_id: int = 1, **overrides) -> JanusParameterSet:
    """Parameter set ``pset_id``, with any field overridden (e.g. ``chip_len_exp=1``).

    Raises
    ------
    ValueError
        Unknown ``pset_id`` without ``fc_hz`` and ``bandwidth_hz`` given.
    """
    from dataclasses import replace

    if pset_id in PARAMETER_SETS:
        return replace(PARAMETER_SETS[pset_id], **overrides)
    if "fc_hz" not in overrides or "bandwidth_hz" not in overrides:
        raise ValueError(f"pset_id must be one of {sorted(PARAMETER_SETS)} unless fc_hz and bandwidth_hz are given, got {pset_id!r}")
    return JanusParameterSet(pset_id=pset_id, name=overrides.pop("name", f"custom {pset_id}"), **overrides)
