"""Bit- and frame-error rates against SNR through the whole chain: beacon → channel scenario → receiver.

Each SNR point is one independent, seeded task (:func:`ber_point`): random
payloads are encoded into a beacon recording, passed through the scenario's
channel with its noise set to that in-band SNR (SPEC §1), and the receiver
detects, measures, compensates, equalises and decodes every frame. Nothing is
known to the receiver but the configuration, the pilot and the emission
times: timing, Doppler and the channel are its own estimates.

Counts per point:

* ``fer_dfe``: frames not delivered by the DFE alone (missed, or CRC failed after pass 1);
* ``fer``: frames not delivered after the turbo passes as well;
* ``raw_ber``: bit error rate of the DFE's hard decisions, before the decoder,
  over the detected frames — the curve to set beside the AWGN theory
  :func:`theory_ber`;
* ``ber``: information-bit error rate after decoding, over the detected frames;
* ``wrong_but_crc_ok``: frames whose CRC passed with wrong bits (the CRC-16's
  miss rate is 2⁻¹⁶ per failed frame: expect 0).

:func:`ber_sweep` maps :func:`ber_point` over the SNRs with any ``map``-like
``mapper`` (serial by default; a process pool or a Dask client's map give the
same numbers, bit for bit, because every point draws from its own seed).
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np
from scipy.special import erfc

from ..config import FrameConfig
from ..errors import ConfigError

__all__ = ["AWGN_SCENARIO", "SweepPoint", "ber_point", "ber_sweep", "point_seed", "theory_ber", "snr_at_fer"]

#: the default scenario: one still path at 100 m, white noise
AWGN_SCENARIO: dict[str, Any] = {
    "mode": "profile",
    "seed": 0,
    "description": "AWGN: one path, no motion, white noise",
    "doppler": {"initial_range_m": 100.0, "components": [{"kind": "constant", "v_mps": 0.0}]},
    "noise": {"kind": "white", "snr_db": 10.0},
}

#: time before the first frame and after the last [s] (the receiver measures noise there)
_LEAD_S = 0.2


@dataclass(frozen=True)
class SweepPoint:
    """Error counts at one SNR (see the module docstring)."""

    snr_db: float
    frames: int
    detected: int
    dfe_ok: int
    turbo_ok: int
    false_detections: int
    wrong_but_crc_ok: int
    info_bits: int
    info_bit_errors: int
    air_bits: int
    air_bit_errors: int
    mean_eq_snr_db: float
    mean_measured_snr_db: float

    @property
    def fer_dfe(self) -> float:
        return 1 - self.dfe_ok / self.frames

    @property
    def fer(self) -> float:
        return 1 - self.turbo_ok / self.frames

    @property
    def ber(self) -> float:
        return self.info_bit_errors / self.info_bits if self.info_bits else math.nan

    @property
    def raw_ber(self) -> float:
        return self.air_bit_errors / self.air_bits if self.air_bits else math.nan

    def row(self) -> dict[str, Any]:
        """The CSV row: counts and rates."""
        out = dict(self.__dict__)
        out.update(fer_dfe=self.fer_dfe, fer=self.fer, ber=self.ber, raw_ber=self.raw_ber)
        return out


def point_seed(seed: int, index: int) -> int:
    """The seed of sweep point ``index``: from (seed, index) only, never from a worker or an order."""
    return int(np.random.SeedSequence([int(seed), int(index)]).generate_state(1)[0])


def _scenario_at(scenario: dict[str, Any], snr_db: float, seed: int) -> dict[str, Any]:
    data = copy.deepcopy(scenario)
    noise = dict(data.get("noise", {}))
    if noise.get("kind", "none") == "none":
        noise = {"kind": "white"}
    noise["snr_db"] = float(snr_db)
    data["noise"] = noise
    data["seed"] = int(seed)
    return data


def ber_point(
    config: dict[str, Any],
    scenario: dict[str, Any],
    snr_db: float,
    *,
    frames: int,
    period_s: float,
    seed: int,
    passes: int = 3,
    base_dir: str = ".",
) -> SweepPoint:
    """Send ``frames`` frames through ``scenario`` at ``snr_db`` and count what the receiver gets.

    Parameters
    ----------
    config : dict
        ``FrameConfig.to_dict()``.
    scenario : dict
        A parsed scenario (TOML tables as dicts); its noise SNR and seed are replaced.
    snr_db : float
        In-band SNR (SPEC §1) [dB].
    frames : int
        Frames sent.
    period_s : float
        T_com [s].
    seed : int
        Seeds the payloads and the scenario's random draws.
    passes : int
        Most equaliser passes (1: DFE alone).
    base_dir : str
        Folder that relative paths in the scenario refer to.

    Returns
    -------
    SweepPoint
    """
    from ..channel.scenario import parse_scenario
    from ..channel.simulate import simulate
    from ..receive import Emissions, Receiver, ReceiverSettings
    from ..transmit.beacon import BeaconSchedule, render_beacon
    from ..transmit.pilot import pilot_bits as make_pilot_bits

    cfg = FrameConfig.from_dict(config)
    sc = parse_scenario(_scenario_at(scenario, snr_db, seed), base_dir=base_dir)
    rng = np.random.default_rng(seed)
    payloads = [bytes(rng.integers(0, 256, cfg.capacity_bytes, dtype=np.uint8)) for _ in range(frames)]
    schedule = BeaconSchedule(count=frames, period_s=period_s, start_s=_LEAD_S)
    bits = make_pilot_bits(cfg.n_pilot, cfg.pilot_seed)
    signal = render_beacon(cfg, schedule, payloads, pilot_bits=bits)
    x = np.concatenate(list(signal.blocks(progress=False)) + [np.zeros(int(_LEAD_S * cfg.sample_rate_hz))])
    emit = schedule.emission_times()
    sim = simulate(
        x,
        cfg.sample_rate_hz,
        sc,
        t_emit_s=emit,
        frame_duration_s=cfg.frame_duration_s,
        band_hz=cfg.data_band_hz,
        reference_frequency_hz=cfg.carrier_hz,
    )
    settings = ReceiverSettings(
        sound_speed_mps=sc.sound_speed_mps,
        clock_offset_s=sc.clock.offset_s if sc.clock is not None else 0.0,
        decode=True,
        turbo_passes=passes,
    )
    rx = Receiver(
        cfg, emissions=Emissions(times_s=emit), settings=settings, pilot=1.0 - 2.0 * bits.astype(float), payloads=payloads
    )
    block = 1 << 20
    records = list(rx.run((sim.output[i : i + block] for i in range(0, sim.output.size, block)), fs=cfg.sample_rate_hz))
    seen: set[int] = set()
    dfe_ok = turbo_ok = false = wrong = 0
    info_err = air_err = info_bits = air_bits = 0
    eq_snr, meas_snr = [], []
    n_air = cfg.n_data * {"bpsk": 1, "qpsk": 2, "8psk": 3}[cfg.modulation]
    for rec in records:
        k = rec.frame_index
        if k < 0 or k >= frames or k in seen or rec.crc_ok is None:
            false += int(k < 0 or k >= frames or k in seen)
            continue
        seen.add(k)
        dfe_ok += int(rec.crc_ok and rec.decode_passes == 1)
        turbo_ok += int(rec.crc_ok)
        wrong += int(bool(rec.crc_ok) and rec.ber > 0)
        info_err += int(round(rec.ber * cfg.n_info_bits))
        info_bits += cfg.n_info_bits
        air_err += int(round(rec.raw_ber * n_air))
        air_bits += n_air
        eq_snr.append(rec.eq_snr_db)
        meas_snr.append(rec.snr_db)
    return SweepPoint(
        snr_db=float(snr_db),
        frames=frames,
        detected=len(seen),
        dfe_ok=dfe_ok,
        turbo_ok=turbo_ok,
        false_detections=false,
        wrong_but_crc_ok=wrong,
        info_bits=info_bits,
        info_bit_errors=info_err,
        air_bits=air_bits,
        air_bit_errors=air_err,
        mean_eq_snr_db=float(np.mean(eq_snr)) if eq_snr else math.nan,
        mean_measured_snr_db=float(np.mean(meas_snr)) if meas_snr else math.nan,
    )


def ber_sweep(
    config: FrameConfig,
    scenario: dict[str, Any] | None,
    snrs_db: Sequence[float],
    *,
    frames: int = 50,
    period_s: float | None = None,
    seed: int = 0,
    passes: int = 3,
    base_dir: str | Path = ".",
    mapper: Callable | None = None,
) -> list[SweepPoint]:
    """:func:`ber_point` at every SNR, mapped with ``mapper`` (default: serial ``map``).

    Parameters
    ----------
    scenario : dict, optional
        Parsed scenario tables; default :data:`AWGN_SCENARIO`.
    period_s : float, optional
        T_com; default the frame duration + 0.2 s.
    mapper : callable, optional
        ``mapper(fn, iterable)`` → results in order, e.g. ``Executor.map``.
    """
    if frames < 1:
        raise ConfigError("frames", f"must be >= 1, got {frames}")
    if passes < 1:
        raise ConfigError("passes", f"must be >= 1, got {passes}")
    if not snrs_db:
        raise ConfigError("snr", "give at least one SNR")
    period = config.frame_duration_s + 0.2 if period_s is None else float(period_s)
    if not period >= config.frame_duration_s:
        raise ConfigError("period", f"must be at least the frame duration {config.frame_duration_s:g} s, got {period:g}")
    tasks = [
        _Task(config.to_dict(), scenario or AWGN_SCENARIO, float(s), frames, period, point_seed(seed, i), passes, str(base_dir))
        for i, s in enumerate(snrs_db)
    ]
    return list((mapper or map)(_run_task, tasks))


@dataclass(frozen=True)
class _Task:
    config: dict
    scenario: dict
    snr_db: float
    frames: int
    period_s: float
    seed: int
    passes: int
    base_dir: str


def _run_task(task: _Task) -> SweepPoint:
    return ber_point(
        task.config,
        task.scenario,
        task.snr_db,
        frames=task.frames,
        period_s=task.period_s,
        seed=task.seed,
        passes=task.passes,
        base_dir=task.base_dir,
    )


def q_function(x):
    """Gaussian tail probability Q(x)."""
    return 0.5 * erfc(np.asarray(x, dtype=float) / math.sqrt(2))


def theory_ber(snr_db, config: FrameConfig) -> np.ndarray:
    """Uncoded AWGN bit error rate at in-band SNR ``snr_db`` (Gray mapping).

    Eb/N0 = SNR·(1 + α)/log2 M, since B = (1 + α)/T. BPSK and QPSK:
    Q(√(2Eb/N0)); 8PSK: the nearest-neighbour approximation
    (2/3)·Q(√(2·3·Eb/N0)·sin(π/8)).
    """
    bps = {"bpsk": 1, "qpsk": 2, "8psk": 3}[config.modulation]
    eb_n0 = 10 ** (np.asarray(snr_db, dtype=float) / 10) * (1 + config.rolloff) / bps
    if bps <= 2:
        return q_function(np.sqrt(2 * eb_n0))
    return (2 / 3) * q_function(np.sqrt(2 * 3 * eb_n0) * math.sin(math.pi / 8))


def snr_at_fer(snrs_db: Sequence[float], fer: Sequence[float], target: float = 0.1) -> float:
    """SNR [dB] where a falling FER curve first crosses ``target`` (linear in dB); NaN if it does not."""
    for i in range(len(fer) - 1):
        if fer[i] > target >= fer[i + 1]:
            a = (fer[i] - target) / (fer[i] - fer[i + 1])
            return float(snrs_db[i] + a * (snrs_db[i + 1] - snrs_db[i]))
    return math.nan
