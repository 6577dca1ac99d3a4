"""Maximal-ratio combining: channels advanced by their direct-path lags and weighted by conj(c_k)/σ²_{c,k}.

The weights are scaled so that the combined noise level equals the
reference channel's; the combined frame is spliced into the reference
channel's basebands with power-preserving ramps.
"""

from __future__ import annotations

import math

import numpy as np


#: frames are combined over [t_a − PAD, t_a + T_F/(1 + v/c) + PAD], joined to the reference channel by ramps
COMBINE_PAD_S, COMBINE_RAMP_S = 0.08, 0.01


def combine_channels(
    x: np.ndarray,
    fs: float,
    lags_s: np.ndarray,
    weights: np.ndarray,
    *,
    complex_gains: np.ndarray | None = None,
) -> np.ndarray:
    """Σ_k Re[w_k · analytic(x_k)(t + δ_k)]: channels advanced by their lags and weighted (real passband out).

    Parameters
    ----------
    x : numpy.ndarray, shape (n_samples, n_channels)
        Real passband channels.
    fs : float
        Their sample rate [Hz].
    lags_s : numpy.ndarray, shape (n_channels,)
        Each channel's delay of the wanted path [s].
    weights : numpy.ndarray, shape (n_channels,), complex
        Combining weights on the analytic signals (MRC: conj(c_k)/σ²_k).
    complex_gains : numpy.ndarray, optional
        Known channel gains, divided out first.

    Returns
    -------
    numpy.ndarray, shape (n_samples,)
        The combined real passband signal.
    """
    n = x.shape[0]
    f = np.fft.rfftfreq(n, 1.0 / fs)
    w = np.asarray(weights, complex)
    if complex_gains is not None:
        w = w / np.asarray(complex_gains)
    spec = np.fft.rfft(x, axis=0) * (w[None, :] * np.exp(2j * np.pi * f[:, None] * np.asarray(lags_s)[None, :]))
    return np.fft.irfft(np.sum(spec, axis=1), n)


def _advance(seg: np.ndarray, fs: float, delays_s: np.ndarray, centre_hz: float) -> np.ndarray:
    """Basebands (n, K) of the passband channels advanced by delays_s: x_bb,k(t + δ_k) e^{j2π fc δ_k}."""
    f = np.fft.fftfreq(seg.shape[0], 1.0 / fs)
    d = np.asarray(delays_s, float)[None, :]
    return np.fft.ifft(np.fft.fft(seg, axis=0) * np.exp(2j * np.pi * f[:, None] * d), axis=0) * np.exp(
        2j * np.pi * centre_hz * d)


def mrc_weights(amplitudes: np.ndarray, snr: np.ndarray, reference_channel: int) -> np.ndarray:
    """Maximal-ratio combining weights conj(c_k)/σ²_{c,k}, scaled so the combined noise is the reference channel's.

    Parameters
    ----------
    amplitudes : numpy.ndarray, shape (n_channels,), complex
        c_k of the direct path (:attr:`DoaEstimate.amplitudes <seamodem.receive.array.DoaEstimate.amplitudes>`).
    snr : numpy.ndarray, shape (n_channels,)
        |c_k|² / σ²_{c,k} (linear).
    reference_channel : int
        The channel whose noise level the combined frame keeps (the noise
        the measurement sees around the frame).

    Returns
    -------
    numpy.ndarray, shape (n_channels,), complex
        The weights on the channels' analytic signals.
    """
    noise = np.abs(amplitudes) ** 2 / snr
    w = np.conj(amplitudes) / noise
    return w * math.sqrt(noise[reference_channel] / np.sum(np.abs(w) ** 2 * noise))


def splice_beam(y: np.ndarray, channels: np.ndarray, fs: float, centre_hz: float, t_from_s: float, t_to_s: float,
                delays_s: np.ndarray, weights: np.ndarray) -> None:
    """y[t_from, t_to] ← Σ_k w_k (channel k advanced by δ_k), cross-faded into y over COMBINE_RAMP_S, in place.

    Parameters
    ----------
    y : numpy.ndarray, shape (n,), complex
        The reference channel's baseband, combined into in place.
    channels : numpy.ndarray, shape (n, n_channels), complex
        Every channel's baseband at the same rate.
    fs : float
        Their rate [Hz].
    centre_hz : float
        The front end's mixing frequency of these basebands [Hz].
    t_from_s, t_to_s : float
        The stretch combined, in the basebands' time [s].
    delays_s : numpy.ndarray, shape (n_channels,)
        Each channel's advance δ_k [s].
    weights : numpy.ndarray, shape (n_channels,), complex
        Combining weights (:func:`mrc_weights`).

    Returns
    -------
    None
        ``y`` is changed in place (left as it is when the stretch holds fewer than 4 samples).
    """
    i0, i1 = max(0, math.floor(t_from_s * fs)), min(len(y), math.ceil(t_to_s * fs))
    if i1 - i0 < 4:
        return
    beam = _advance(channels[i0:i1], fs, delays_s, centre_hz) @ weights
    ramp = np.ones(i1 - i0)
    nr = max(1, min(round(COMBINE_RAMP_S * fs), (i1 - i0) // 2))
    edge = np.sin(0.5 * np.pi * (np.arange(nr) + 0.5) / nr)  # power-preserving cross-fade (independent noises)
    ramp[:nr], ramp[-nr:] = edge, edge[::-1]
    y[i0:i1] = ramp * beam + np.sqrt(1.0 - ramp**2) * y[i0:i1]
