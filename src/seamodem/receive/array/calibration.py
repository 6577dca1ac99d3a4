"""Channel gains and phases (and element position errors) from frames whose direction is known."""

from __future__ import annotations

import math

import numpy as np

from ...config import FrameConfig
from ...errors import ConfigError
from ...transmit.pilot import pilot_symbols
from .correlation import array_correlation
from .doa import coarse_lags, correlation_snr, later_paths
from .geometry import unit_vector


#: prior std of each element's position error when they are estimated [m]: directions the calibration frames
#: do not span (e.g. the vertical, when every frame has the same elevation) are left at zero error
POSITION_PRIOR_M = 0.005


def calibrate_array(
    x: np.ndarray,
    fs: float,
    config: FrameConfig,
    positions_m: np.ndarray,
    *,
    arrivals_s,
    directions_body_rad,
    v_mps=None,
    sound_speed_mps: float,
    pilot: np.ndarray | None = None,
    estimate_positions: bool = False,
    position_prior_m: float = POSITION_PRIOR_M,
):
    """Channel gain [dB] and phase [rad] offsets, and optionally element position errors, from frames whose
    direction is known.

    For each frame the plane wave's lags are those of the known body-frame
    direction u_f (the common arrival t0 fitted on the envelope); c_k / c_0 at
    those lags is channel k's complex gain relative to channel 0. Gains are
    averaged over frames weighted by their SNR.

    ``estimate_positions``: an element displaced by e_k from its nominal
    position reaches the wave e_k·u_f/c earlier, so the phase of c_k / c_0
    left after the mean gain turns, frame by frame, as

        s_{k,f} = −arg(c_k c_0* / g_k) / (2π f0) = −(e_k − e_0)·u_f / c + b_k,

    linear in (e_k − e_0, b_k) (b_k: the part of the channel's phase offset the
    mean did not take). Per channel, weighted least squares over the frames
    (weights from each frame's SNR on channels k and 0) with a prior of
    ``position_prior_m`` on each coordinate, which leaves at zero what the
    frames' directions do not separate from a constant phase (with every frame
    at one elevation, the vertical component); the phase offset becomes
    arg g_k − 2π f0 b_k. The errors are returned about their mean (a common
    translation of the array only shifts t0: it is not measured).
    Frames at several azimuths *and* elevations determine all three components.

    Parameters
    ----------
    x : numpy.ndarray, shape (n_samples, n_channels)
    positions_m : numpy.ndarray, shape (n_channels, 3)
        Element positions in the body frame [m].
    arrivals_s : sequence of float
        Each frame's arrival (e.g. a receiver's ``t_arrival_s``) [s].
    directions_body_rad : sequence of (azimuth, elevation)
        The direct path's known direction for each frame [rad].
    v_mps : sequence of float, optional
        Closing speeds [m/s] (default 0).
    estimate_positions : bool
        Also estimate the element position errors (needs frames from at least
        three directions not in one plane through the origin, or fewer
        components are determined).
    position_prior_m : float
        Prior std of each position error coordinate [m] (``estimate_positions``).

    Returns
    -------
    gain_db, phase_rad : numpy.ndarray, shape (n_channels,)
        Channel 0 is the reference (0 dB, 0 rad): give them to
        :class:`~seamodem.channel.array.ReceiverArray` (or ``complex_gains``
        10^(g/20)·e^{jφ}) for the receiver to remove.
    position_errors_m : numpy.ndarray, shape (n_channels, 3)
        Only with ``estimate_positions``: true − nominal positions, about
        their mean; the receiver takes ``positions_m + position_errors_m`` (and
        the phases returned with them).

    Raises
    ------
    ConfigError
        Not one direction and speed per arrival, or a non-positive prior.
    """
    p = np.asarray(positions_m, float)
    c = sound_speed_mps
    pilot = pilot_symbols(config.n_pilot, config.pilot_seed) if pilot is None else np.asarray(pilot, complex)
    arrivals = np.atleast_1d(np.asarray(arrivals_s, float))
    dirs = np.asarray(directions_body_rad, float).reshape(-1, 2)
    v = np.zeros(arrivals.size) if v_mps is None else np.asarray(v_mps, float).reshape(-1)
    if not (len(dirs) == arrivals.size == v.size) or arrivals.size == 0:
        raise ConfigError("directions_body_rad", "needs one direction (and speed) per arrival, at least one")
    if estimate_positions and not (math.isfinite(position_prior_m) and position_prior_m > 0):
        raise ConfigError("position_prior_m", f"must be > 0 m, got {position_prior_m!r}")
    ratios, snrs, units = [], [], []
    for t_a, (az, el), vk in zip(arrivals, dirs, v):
        corr = array_correlation(x, fs, config=config, pilot=pilot, t_arrival_s=t_a, v_mps=vk, sound_speed_mps=c)
        u = unit_vector(az, el)
        rel = -p @ u / c
        coarse = coarse_lags(corr, float(np.max(np.abs(rel))) + 0.25 / config.symbol_rate_hz)
        t0 = float(np.mean(coarse - rel))
        amp = corr.at(t0 + rel)
        # echoes resolved from the direct path removed first (as estimate_doa, step 2b): a calibration run's
        # geometry repeats, so their pilot sidelobes at the direct lag bias every frame alike (0.36 dB and
        # 0.033 rad on the lower elements of a tetrahedron under a surface and a bottom echo, 24 frames)
        echo_lags, echo_amps = later_paths(corr, t0 + rel, amp / corr.energy, fs=corr.fs_hz,
                                           after_s=0.75 / config.symbol_rate_hz)
        if echo_lags.size:
            amp = corr.without(echo_lags, echo_amps).at(t0 + rel)
        ratios.append(amp / amp[0])
        snrs.append(correlation_snr(amp, corr.noise_var))
        units.append(u)
    ratios, snrs, units = np.array(ratios), np.array(snrs), np.array(units)
    weight = snrs[:, 0]
    g = np.sum(weight[:, None] * ratios, axis=0) / np.sum(weight)
    # the gain from the mean magnitude: a phase that turns from frame to frame (position errors) would shrink
    # the complex mean's (by 0.1 dB with ±2 mm on 8 cm)
    gain_db = 20.0 * np.log10(np.sum(weight[:, None] * np.abs(ratios), axis=0) / np.sum(weight))
    phase_rad = np.angle(g)
    if not estimate_positions:
        return gain_db, phase_rad
    f0 = config.carrier_hz
    s_kf = -np.angle(ratios / g[None, :]) / (2 * np.pi * f0)  # (frames, channels), small once g is removed
    # variance of each frame's phase difference: 1/(2 SNR) per channel, in delay units
    var = (1.0 / (2.0 * snrs) + 1.0 / (2.0 * snrs[:, :1])) / (2 * np.pi * f0) ** 2
    d = np.zeros((p.shape[0], 3))
    design = np.column_stack([-units / c, np.ones(len(units))])
    prior = np.zeros((3, 4))
    prior[:, :3] = np.eye(3) / position_prior_m
    for k in range(1, p.shape[0]):
        sw = 1.0 / np.sqrt(var[:, k])
        A = np.vstack([sw[:, None] * design, prior])
        y = np.concatenate([sw * s_kf[:, k], np.zeros(3)])
        sol = np.linalg.lstsq(A, y, rcond=None)[0]
        d[k] = sol[:3]
        phase_rad[k] = float(np.angle(g[k] * np.exp(-2j * np.pi * f0 * sol[3])))
    return gain_db, phase_rad, d - d.mean(axis=0)
