"""The JANUS 64-bit base packet: fields, CRC-8, and class 16 / application type 0 data.

Layout (bit 0 is the MSB of byte 0, sent first): version (4 bits), mobility, schedule,
tx/rx and forwarding flags, class user id (8), application type (6), application data (34),
CRC-8 (polynomial 0x07, initial 0, MSB first, no final XOR) over bytes 0-6.

Class 16 application type 0 (the reference's plugin) puts, counting application-data bits
with 0 as the last before the CRC, the station id in bits 25..18, the parameter-set id in
bits 17..6 and the cargo-size index in bits 5..0.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

__all__ = [
    "JanusPacket",
    "crc8",
    "cargo_size",
    "cargo_index",
    "bytes_to_bits",
    "bits_to_bytes",
    "MAX_CARGO_BYTES",
    "JANUS_VERSION",
]

JANUS_VERSION = 3
MAX_CARGO_BYTES = 480
_APP_DATA_BITS = 34


def crc8(data: bytes) -> int:
    """CRC-8, polynomial x⁸ + x² + x + 1 (0x07), initial 0, MSB first, no reflection, no final XOR.

    Examples
    --------
    >>> hex(crc8(bytes.fromhex("32100000000000")))
    '0x55'
    """
    c = 0
    for byte in data:
        c ^= byte
        for _ in range(8):
            c = ((c << 1) ^ 0x07) & 0xFF if c & 0x80 else (c << 1) & 0xFF
    return c


def cargo_size(index: int) -> int:
    """Cargo bytes announced by a class-16 app-0 cargo-size index (0, 1, 2, 4, then 8·(n − 3))."""
    if not 0 <= index < 64:
        raise ValueError(f"cargo index must be in [0, 63], got {index!r}")
    return (0, 1, 2, 4)[index] if index < 4 else 8 * (index - 3)


def cargo_index(n_bytes: int) -> int:
    """Smallest cargo-size index whose size holds ``n_bytes`` (at most 480)."""
    if not 0 <= n_bytes <= MAX_CARGO_BYTES:
        raise ValueError(f"cargo must be 0 to {MAX_CARGO_BYTES} bytes, got {n_bytes}")
    for index in range(64):
        if cargo_size(index) >= n_bytes:
            return index
    raise AssertionError("unreachable: index 63 holds 480 bytes")


def bytes_to_bits(data: bytes) -> np.ndarray:
    """Bytes → bits, MSB first, shape (8·len(data),) uint8."""
    return np.unpackbits(np.frombuffer(bytes(data), dtype=np.uint8))


def bits_to_bytes(bits: np.ndarray) -> bytes:
    """Bits (MSB first, a multiple of 8) → bytes."""
    return np.packbits(np.asarray(bits, dtype=np.uint8)).tobytes()


@dataclass(frozen=True, kw_only=True)
class JanusPacket:
    """A JANUS base packet and its cargo.

    Parameters
    ----------
    version : int
        4-bit version number (3).
    mobility, schedule, tx_rx, forward : bool
        The four flags.
    class_user_id : int
        8-bit class user identifier (16: the NATO JANUS reference implementation).
    application_type : int
        6-bit application type.
    application_data : int
        34-bit application data (for class 16 / type 0, see :meth:`class16_app0`).
    cargo : bytes
        Cargo bytes, sent as their own coded block after the base packet.
    """

    version: int = JANUS_VERSION
    mobility: bool = False
    schedule: bool = False
    tx_rx: bool = True
    forward: bool = False
    class_user_id: int = 16
    application_type: int = 0
    application_data: int = 0
    cargo: bytes = field(default=b"")

    def __post_init__(self):
        for name, bits in (("version", 4), ("class_user_id", 8), ("application_type", 6), ("application_data", 34)):
            value = getattr(self, name)
            if not 0 <= value < (1 << bits):
                raise ValueError(f"{name} must be in [0, {(1 << bits) - 1}], got {value!r}")
        if len(self.cargo) > 4096:
            raise ValueError(f"cargo must be at most 4096 bytes, got {len(self.cargo)}")

    @classmethod
    def class16_app0(
        cls,
        *,
        station_id: int = 0,
        pset_id: int = 0,
        cargo: bytes = b"",
        mobility: bool = False,
        tx_rx: bool = True,
        forward: bool = False,
    ) -> "JanusPacket":
        """Class 16, application type 0: station id, parameter-set id and a cargo padded to its announced size.

        Parameters
        ----------
        station_id : int
            8-bit station identifier.
        pset_id : int
            12-bit parameter-set identifier field.
        cargo : bytes
            At most 480 bytes; padded with zeros to the next size the index can announce.
        mobility, tx_rx, forward : bool
            Flags.
        """
        if not 0 <= station_id < 256:
            raise ValueError(f"station_id must be in [0, 255], got {station_id!r}")
        if not 0 <= pset_id < 4096:
            raise ValueError(f"pset_id must be in [0, 4095], got {pset_id!r}")
        index = cargo_index(len(cargo))
        padded = bytes(cargo) + bytes(cargo_size(index) - len(cargo))
        data = (station_id << 18) | (pset_id << 6) | index
        return cls(mobility=mobility, tx_rx=tx_rx, forward=forward, class_user_id=16, application_type=0,
                   application_data=data, cargo=padded)

    def header_bytes(self) -> bytes:
        """Bytes 0-6 (before the CRC)."""
        word = (self.version << 60) | (int(self.mobility) << 59) | (int(self.schedule) << 58)
        word |= (int(self.tx_rx) << 57) | (int(self.forward) << 56) | (self.class_user_id << 48)
        word |= (self.application_type << 42) | (self.application_data << 8)
        return (word >> 8).to_bytes(7, "big")

    def to_bytes(self) -> bytes:
        """The 8 packet bytes, CRC last."""
        head = self.header_bytes()
        return head + bytes([crc8(head)])

    @classmethod
    def from_bytes(cls, packet: bytes, cargo: bytes = b"") -> "JanusPacket":
        """Fields of 8 packet bytes (the CRC is not checked here: see :func:`crc8`)."""
        if len(packet) != 8:
            raise ValueError(f"a JANUS packet is 8 bytes, got {len(packet)}")
        word = int.from_bytes(packet, "big")
        return cls(
            version=word >> 60, mobility=bool(word >> 59 & 1), schedule=bool(word >> 58 & 1),
            tx_rx=bool(word >> 57 & 1), forward=bool(word >> 56 & 1), class_user_id=word >> 48 & 0xFF,
            application_type=word >> 42 & 0x3F, application_data=word >> 8 & ((1 << _APP_DATA_BITS) - 1),
            cargo=bytes(cargo),
        )

    @property
    def is_class16_app0(self) -> bool:
        """Whether the application data follows the reference plugin's layout."""
        return self.class_user_id == 16 and self.application_type == 0

    @property
    def announced_cargo_bytes(self) -> int:
        """Cargo size the packet announces (class 16 / type 0; 0 otherwise)."""
        return cargo_size(self.application_data & 0x3F) if self.is_class16_app0 else 0

    def fields(self) -> dict:
        """Every field by name, the class-16 app-0 ones included when they apply (JSON-ready)."""
        out = asdict(self)
        out["cargo"] = self.cargo.hex()
        out["crc"] = self.to_bytes()[7]
        if self.is_class16_app0:
            out["station_id"] = self.application_data >> 18 & 0xFF
            out["pset_id"] = self.application_data >> 6 & 0xFFF
            out["cargo_size"] = self.announced_cargo_bytes
        return out
