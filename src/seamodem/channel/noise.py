"""Additive noise, generated block by block: white, coloured ambient, impulsive.

Every source produces samples of *nominal power 1*; the simulator scales them
to the requested in-band SNR (SPEC §1) using :meth:`NoiseSource.in_band_fraction`,
the share of that nominal power inside the data band.

- ``white``: Gaussian, variance 1.
- ``ambient``: Gaussian, coloured by an FIR whose power response follows the
  empirical ocean-noise spectrum of Coates (1990) as written by Stojanovic
  (2007): turbulence 17 − 30 log f, shipping 40 + 20(s − 0.5) + 26 log f −
  60 log(f + 0.03), wind 50 + 7.5 √w + 20 log f − 40 log(f + 0.4), thermal
  −15 + 20 log f (dB re 1 µPa²/Hz, f in kHz); flat below 100 Hz, where an FIR
  of this length cannot follow it. Variance 1.
- ``gaussian_mixture`` (snapping shrimp): each sample is N(0, σ²) and, with
  probability p, N(0, κσ²) instead; σ² = 1/((1 − p) + pκ) so the variance is 1.
- ``alpha_stable`` (snapping shrimp): symmetric α-stable (Chambers–Mallows–Stuck),
  scaled by 1/√2 so that α = 2 is N(0, 1). For α < 2 the variance is
  infinite: "power 1" then means a dispersion γ = 1/√2, the Gaussian value.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.signal

__all__ = ["NoiseSource", "WhiteNoise", "AmbientNoise", "GaussianMixtureNoise", "AlphaStableNoise", "ambient_psd_db"]


def ambient_psd_db(frequency_hz, *, shipping: float, wind_mps: float) -> np.ndarray:
    """Ocean ambient noise PSD [dB re 1 µPa²/Hz] (Coates 1990, in Stojanovic 2007 eq 3).

    Parameters
    ----------
    frequency_hz : float or array_like
        Frequencies [Hz], > 0.
    shipping : float
        Shipping activity factor s, 0 (none) to 1 (heavy).
    wind_mps : float
        Wind speed w [m/s].

    Returns
    -------
    numpy.ndarray
        Sum of the turbulence, shipping, wind and thermal terms
        [dB re 1 µPa²/Hz], same shape as ``frequency_hz``.
    """
    f = np.asarray(frequency_hz, dtype=float) / 1e3
    turbulence = 17.0 - 30.0 * np.log10(f)
    ships = 40.0 + 20.0 * (shipping - 0.5) + 26.0 * np.log10(f) - 60.0 * np.log10(f + 0.03)
    wind = 50.0 + 7.5 * math.sqrt(wind_mps) + 20.0 * np.log10(f) - 40.0 * np.log10(f + 0.4)
    thermal = -15.0 + 20.0 * np.log10(f)
    return 10.0 * np.log10(sum(10.0 ** (x / 10.0) for x in (turbulence, ships, wind, thermal)))


class NoiseSource:
    """A stream of noise samples of nominal power 1.

    The base class; :class:`WhiteNoise`, :class:`AmbientNoise`,
    :class:`GaussianMixtureNoise` and :class:`AlphaStableNoise` implement
    :meth:`block`.

    Parameters
    ----------
    fs : float
        Sample rate [Hz].
    rng : numpy.random.Generator
        Source of the random draws; consumed block after block.

    Attributes
    ----------
    kind : str
        Scenario name of the noise type (``"white"``, ``"ambient"``, ...).
    fs : float
        Sample rate [Hz].
    rng : numpy.random.Generator
        The generator given.
    """

    kind = "white"

    def __init__(self, fs: float, rng: np.random.Generator):
        self.fs = float(fs)
        self.rng = rng

    def in_band_fraction(self, band_hz: tuple[float, float]) -> float:
        """Share of the nominal power inside ``band_hz`` (white: 2B/fs).

        Parameters
        ----------
        band_hz : tuple of float
            Band edges ``(low, high)`` [Hz].

        Returns
        -------
        float
            Fraction of the nominal power 1 inside the band, in [0, 1].
        """
        lo, hi = band_hz
        return 2.0 * (min(hi, self.fs / 2) - max(lo, 0.0)) / self.fs

    def block(self, n: int) -> np.ndarray:
        """The next ``n`` samples.

        Parameters
        ----------
        n : int
            Number of samples.

        Returns
        -------
        numpy.ndarray
            Real samples, shape ``(n,)``, continuing the previous block.
        """
        raise NotImplementedError


class WhiteNoise(NoiseSource):
    """White Gaussian noise of variance 1.

    Parameters
    ----------
    fs : float
        Sample rate [Hz].
    rng : numpy.random.Generator
        Source of the random draws.
    """

    kind = "white"

    def block(self, n):
        return self.rng.standard_normal(n)


class AmbientNoise(NoiseSource):
    """Gaussian noise coloured like the ocean's ambient noise (module docstring).

    White noise filtered by an ``N_TAPS``-tap FIR of unit energy whose power
    response follows :func:`ambient_psd_db` (flat below 100 Hz); variance 1.

    Parameters
    ----------
    fs : float
        Sample rate [Hz].
    rng : numpy.random.Generator
        Source of the random draws.
    shipping : float
        Shipping activity factor, 0 to 1.
    wind_mps : float
        Wind speed [m/s].

    Attributes
    ----------
    taps : numpy.ndarray
        The colouring FIR, shape ``(N_TAPS,)``, unit energy.
    """

    kind = "ambient"
    N_TAPS = 513

    def __init__(self, fs, rng, *, shipping: float, wind_mps: float):
        super().__init__(fs, rng)
        freqs = np.linspace(0.0, fs / 2, 1025)
        psd_db = ambient_psd_db(np.maximum(freqs, 100.0), shipping=shipping, wind_mps=wind_mps)
        gain = 10.0 ** ((psd_db - psd_db.max()) / 20.0)
        taps = scipy.signal.firwin2(self.N_TAPS, freqs, gain, fs=fs)
        self.taps = taps / np.sqrt(np.sum(taps**2))
        self._history = rng.standard_normal(self.N_TAPS - 1)

    def in_band_fraction(self, band_hz):
        n_fft = 1 << 16
        power = np.abs(np.fft.rfft(self.taps, n_fft)) ** 2
        f = np.fft.rfftfreq(n_fft, 1.0 / self.fs)
        inside = (f >= band_hz[0]) & (f <= band_hz[1])
        # Parseval with unit-energy taps: |H_0|² + 2 Σ|H_k|² + |H_N/2|² = n_fft
        return float(2.0 * np.sum(power[inside]) / n_fft)

    def block(self, n):
        w = np.concatenate([self._history, self.rng.standard_normal(n)])
        self._history = w[-(self.N_TAPS - 1):]
        return scipy.signal.oaconvolve(w, self.taps, mode="valid")


class GaussianMixtureNoise(NoiseSource):
    """Impulsive two-term Gaussian mixture noise of variance 1 (snapping shrimp).

    Each sample is N(0, σ²), or with probability ``impulse_probability``
    N(0, κσ²), κ = ``impulse_power_ratio``; σ² = 1/((1 − p) + pκ).

    Parameters
    ----------
    fs : float
        Sample rate [Hz].
    rng : numpy.random.Generator
        Source of the random draws.
    impulse_probability : float
        Probability p that a sample is an impulse, in [0, 1].
    impulse_power_ratio : float
        Power ratio κ of an impulse to a background sample [linear].

    Attributes
    ----------
    p : float
        ``impulse_probability``.
    ratio : float
        ``impulse_power_ratio``.
    sigma : float
        Standard deviation σ of a background sample.
    """

    kind = "gaussian_mixture"

    def __init__(self, fs, rng, *, impulse_probability: float, impulse_power_ratio: float):
        super().__init__(fs, rng)
        self.p = impulse_probability
        self.ratio = impulse_power_ratio
        self.sigma = 1.0 / math.sqrt((1.0 - self.p) + self.p * self.ratio)

    def block(self, n):
        scale = np.where(self.rng.random(n) < self.p, self.sigma * math.sqrt(self.ratio), self.sigma)
        return scale * self.rng.standard_normal(n)


class AlphaStableNoise(NoiseSource):
    """Symmetric α-stable noise (Chambers–Mallows–Stuck), dispersion 1/√2.

    Scaled so that α = 2 gives N(0, 1); for α < 2 the variance is infinite.

    Parameters
    ----------
    fs : float
        Sample rate [Hz].
    rng : numpy.random.Generator
        Source of the random draws.
    alpha : float
        Characteristic exponent α in (0, 2]; smaller is more impulsive
        (1 is Cauchy).
    """

    kind = "alpha_stable"

    def __init__(self, fs, rng, *, alpha: float):
        super().__init__(fs, rng)
        self.alpha = alpha

    def block(self, n):
        a = self.alpha
        u = np.pi * (self.rng.random(n) - 0.5)
        w = self.rng.standard_exponential(n)
        if a == 1.0:
            x = np.tan(u)
        else:
            x = np.sin(a * u) / np.cos(u) ** (1.0 / a) * (np.cos(u - a * u) / w) ** ((1.0 - a) / a)
        return x / math.sqrt(2.0)
