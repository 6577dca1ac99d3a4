"""A channel corpus nobody tuned to (issue 25): randomized geometries, surfaces, bottoms and noises.

The channel here is written independently of ``seamodem.channel``: image
sources over a flat bottom and a moving sea surface, each path's delay solved
from its own geometry at every output sample (so every path carries its own
Doppler), per-path Rician fading, and the received passband built by
windowed-sinc interpolation of the transmitted analytic signal. Noise: white,
impulsive clicks, Gaussian mixture, symmetric α-stable (Chambers–Mallows–Stuck).
SNR is in-band (SPEC §1): received signal power (all paths) over noise power in
[f0 − B/2, f0 + B/2] over the frames.

Families (each a preset of random draws):

- ``steep``: vehicle circling 8–15 m from the beacon in 15–25 m of water:
  surface and bottom echoes 2–30 ms behind with Doppler far from the direct path's;
- ``far``: 600–1000 m in 10–20 m of shallow water, near-surface ends: the surface
  echo merges with the direct path (Lloyd's mirror), its phase riding the waves;
- ``fading``: 80–400 m, every echo Rician-fading (K 0–10 dB, spread 0.2–2 Hz),
  the direct path too on some draws (K 6–20 dB);
- ``impulsive``: 50–400 m with clicks, Gaussian mixture or α-stable noise.

Every family has waves (amplitude 0.05–0.5 m, period 3–9 s) moving the surface
images, and a random bottom (rock, sand, mud). In-band SNR is drawn in [−3, 20] dB.

Truth per frame: the direct path's reception time of the frame start
(``t_arrival``), ``range = c·tof`` and ``v_r = c (T_F − D_rx) / D_rx`` from its
reception duration D_rx (SPEC §1: mean closing speed over the frame).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from scipy.signal import hilbert
from scipy.special import i0 as bessel_i0

C = 1500.0
FAMILIES = ("steep", "far", "fading", "impulsive")
TAPS = 64  # windowed-sinc interpolator length (error floor below −70 dB over the band)
BOTTOMS = {"rock": (0.6, 0.85), "sand": (0.3, 0.6), "mud": (0.08, 0.3)}


@dataclass
class Scenario:
    """One corpus recording: geometry, surface, bottom, fading and noise draws."""

    family: str
    seed: int
    snr_db: float
    depth_m: float
    beacon: np.ndarray
    track: dict
    wave_amp_m: float
    wave_period_s: float
    wave_phase: float
    bottom: str
    bottom_gain: float
    surface_gain: float
    fading: dict = field(default_factory=dict)
    noise: dict = field(default_factory=dict)

    def describe(self) -> str:
        return (f"{self.family} seed {self.seed}: {self.snr_db:.1f} dB, depth {self.depth_m:.0f} m, "
                f"{self.track['kind']}, waves {self.wave_amp_m:.2f} m/{self.wave_period_s:.1f} s, "
                f"{self.bottom}, noise {self.noise.get('kind')}")


def draw_scenario(family: str, seed: int) -> Scenario:
    """Random draws of one family's preset."""
    rng = np.random.default_rng(seed)
    u = rng.uniform
    bottom = str(rng.choice(list(BOTTOMS)))
    common = dict(family=family, seed=seed, snr_db=float(u(-3.0, 20.0)), wave_amp_m=float(u(0.05, 0.5)),
                  wave_period_s=float(u(3.0, 9.0)), wave_phase=float(u(0, 2 * np.pi)), bottom=bottom,
                  bottom_gain=float(u(*BOTTOMS[bottom])), surface_gain=-float(u(0.8, 0.98)))
    heading = u(0, 2 * np.pi)
    if family == "steep":
        depth = u(15.0, 25.0)
        beacon = np.array([0.0, 0.0, -u(4.0, depth - 4.0)])
        radius = u(8.0, 15.0)
        offset = u(0.0, 0.6) * radius  # circle centre off the beacon: the range breathes
        track = dict(kind="circle", centre=np.array([offset * np.cos(heading), offset * np.sin(heading)]),
                     radius=radius, speed=u(0.8, 1.6) * rng.choice([-1, 1]), phase=u(0, 2 * np.pi),
                     z=-u(2.0, depth - 2.0))
        return Scenario(depth_m=depth, beacon=beacon, track=track, noise={"kind": "white"}, **common)
    if family == "far":
        depth = u(10.0, 20.0)
        beacon = np.array([0.0, 0.0, -u(1.5, 5.0)])
        r0 = u(600.0, 1000.0)
        track = _line(rng, r0, depth, z=-u(1.5, 5.0))
        return Scenario(depth_m=depth, beacon=beacon, track=track, noise={"kind": "white"}, **common)
    depth = u(20.0, 60.0)
    beacon = np.array([0.0, 0.0, -u(3.0, depth - 3.0)])
    track = _line(rng, u(80.0, 400.0) if family == "fading" else u(50.0, 400.0), depth, z=-u(2.0, depth - 2.0))
    if family == "fading":
        fading = dict(k_db=float(u(0.0, 10.0)), spread_hz=float(u(0.2, 2.0)),
                      direct_k_db=float(u(6.0, 20.0)) if rng.random() < 0.5 else math.inf)
        return Scenario(depth_m=depth, beacon=beacon, track=track, fading=fading, noise={"kind": "white"}, **common)
    kind = str(rng.choice(["clicks", "gaussian_mixture", "alpha_stable"]))
    noise = {"kind": kind}
    if kind == "clicks":
        noise.update(rate_hz=float(u(20.0, 300.0)), level_db=float(u(15.0, 35.0)))
    elif kind == "gaussian_mixture":
        noise.update(p=float(10 ** u(-3.5, -1.5)), ratio_db=float(u(15.0, 30.0)))
    else:
        noise.update(alpha=float(u(1.5, 1.95)))
    return Scenario(depth_m=depth, beacon=beacon, track=track, noise=noise, **common)


def _line(rng, r0: float, depth: float, *, z: float) -> dict:
    """A straight leg starting r0 from the beacon, heading anywhere from straight in to straight out."""
    bearing = rng.uniform(0, 2 * np.pi)
    start = r0 * np.array([np.cos(bearing), np.sin(bearing)])
    course = bearing + np.pi + rng.uniform(-np.pi, np.pi)
    speed = rng.uniform(0.3, 2.0)
    return dict(kind="line", start=start, velocity=speed * np.array([np.cos(course), np.sin(course)]), z=z)


def receiver_position(sc: Scenario, t: np.ndarray) -> np.ndarray:
    """Receiver position at times t: (n, 3); z climbs at the track's ``climb_mps`` [m/s] when it has one (a
    vehicle diving or surfacing; the drawn tracks keep their depth)."""
    tr = sc.track
    if tr["kind"] == "circle":
        ang = tr["phase"] + tr["speed"] / tr["radius"] * t
        xy = tr["centre"][None, :] + tr["radius"] * np.stack([np.cos(ang), np.sin(ang)], axis=1)
    else:
        xy = tr["start"][None, :] + t[:, None] * tr["velocity"][None, :]
    z = tr["z"] + tr.get("climb_mps", 0.0) * np.asarray(t, dtype=float)
    return np.concatenate([xy, z[:, None]], axis=1)


def surface_height(sc: Scenario, t: np.ndarray) -> np.ndarray:
    return sc.wave_amp_m * np.sin(2 * np.pi * t / sc.wave_period_s + sc.wave_phase)


def _image_z(sc: Scenario, path: str, eta: np.ndarray) -> np.ndarray:
    """z of the beacon's image for a path name of S/B bounces (the last bounce is nearest the receiver)."""
    z = np.full_like(eta, sc.beacon[2])
    for bounce in path:
        z = 2 * eta - z if bounce == "S" else -2 * sc.depth_m - z
    return z


PATHS = ("D", "S", "B", "SB", "BS")


def path_delay(sc: Scenario, path: str, t: np.ndarray) -> np.ndarray:
    """Propagation time of a path for reception times t, the images at emission time (fixed point)."""
    rx = receiver_position(sc, t)
    tau = np.zeros_like(t)
    for _ in range(6):
        te = t - tau
        img = np.stack([np.full_like(t, sc.beacon[0]), np.full_like(t, sc.beacon[1]),
                        _image_z(sc, "" if path == "D" else path, surface_height(sc, te))], axis=1)
        tau = np.linalg.norm(rx - img, axis=1) / C
    return tau


def path_gain(sc: Scenario, path: str, length_m: float, direct_m: float) -> float:
    """Amplitude relative to the direct path: reflections, spherical spreading."""
    g = 1.0
    for bounce in "" if path == "D" else path:
        g *= sc.surface_gain if bounce == "S" else sc.bottom_gain
    return g * direct_m / length_m


def reception_time(sc: Scenario, t_emit: float, path: str = "D") -> float:
    """Reception time of a signal instant emitted at t_emit along a path (fixed point on t − τ(t) = t_emit)."""
    t = t_emit
    for _ in range(9):
        t = t_emit + float(path_delay(sc, path, np.array([t]))[0])
    return t


def _fading(rng, n_sin: int, spread_hz: float):
    """A unit-power complex Gaussian process with a Gaussian Doppler spectrum (sum of sinusoids)."""
    f = rng.normal(0.0, spread_hz, n_sin)
    ph = rng.uniform(0, 2 * np.pi, n_sin)
    return lambda t: np.exp(1j * (2 * np.pi * f[None, :] * t[:, None] + ph[None, :])).sum(axis=1) / math.sqrt(n_sin)


#: the interpolator's kernel h(d), a Kaiser-windowed sinc (β 8, cut-off 0.42 fs), tabulated at 1/KERNEL_STEPS of a
#: sample and read linearly between: 5e-9 of its peak off the formula (the Kaiser window's Bessel function on every
#: tap of every output sample took 3/4 of a corpus recording's time; `tests/test_corpus_interp.py`)
KERNEL_STEPS = 4096
_TAP_OFFSETS = np.arange(-TAPS // 2 + 1, TAPS // 2 + 1)


def kaiser_sinc(d: np.ndarray) -> np.ndarray:
    """The interpolator's kernel at offsets d [samples] (zero beyond ±TAPS/2)."""
    w = bessel_i0(8.0 * np.sqrt(np.clip(1 - (d / (TAPS / 2)) ** 2, 0, None))) / bessel_i0(8.0)
    return 2 * 0.42 * np.sinc(2 * 0.42 * d) * w


#: row j: the kernel's TAPS taps for a fractional delay of j / KERNEL_STEPS
_KERNEL_TABLE = kaiser_sinc(np.arange(KERNEL_STEPS + 2)[:, None] / KERNEL_STEPS - _TAP_OFFSETS[None, :])


def padded(xa: np.ndarray) -> np.ndarray:
    """The analytic signal with TAPS zeros on each side, as :func:`_interp` reads it."""
    z = np.zeros(TAPS, xa.dtype)
    return np.concatenate([z, xa, z])


def _interp(xp: np.ndarray, fs: float, times: np.ndarray) -> np.ndarray:
    """Band-limited value at arbitrary times [s] of the sampled signal that :func:`padded` gave xp
    (Kaiser-windowed sinc, cut-off 0.42 fs); zero where its taps miss the signal."""
    u = times * fs
    first = np.floor(u).astype(np.int64)
    pos = (u - first) * KERNEL_STEPS
    row = np.minimum(pos.astype(np.int64), KERNEL_STEPS - 1)
    a = (pos - row)[:, None]
    h = _KERNEL_TABLE[row] * (1 - a) + _KERNEL_TABLE[row + 1] * a
    windows = sliding_window_view(xp, TAPS)  # windows[i] = x[i - TAPS : i]
    start = first + _TAP_OFFSETS[0] + TAPS
    inside = (start >= 0) & (start < len(windows))
    return np.where(inside, np.einsum("ij,ij->i", windows[np.clip(start, 0, len(windows) - 1)], h), 0)


@dataclass
class Recording:
    scenario: Scenario
    samples: np.ndarray
    fs: float
    t_emit: np.ndarray
    payloads: list
    truth: list  # per frame: t_arrival, range, v_r, paths [(name, delay_s, v_r, amplitude)]
    clean_power: float


def synthesize(sc: Scenario, beacon, t_emit: np.ndarray, fs: float, frame_s: float, band: tuple[float, float],
               *, echoes: bool = True, chunk: int = 8192, only_paths: tuple | None = None) -> Recording:
    """The received recording of a rendered beacon through the scenario's channel, with noise, and its truth;
    ``only_paths`` (names from :data:`PATHS`, "D" among them) keeps those paths alone, with the geometry,
    gains and Doppler they have in the full recording (which path makes what a receiver does:
    diagnose_corpus.py --paths); the noise keeps the nominal SNR over the paths kept, and a fading
    family's fading draws follow the paths kept."""
    if only_paths is not None:
        unknown = sorted(set(only_paths) - set(PATHS))
        if unknown or "D" not in only_paths:
            raise ValueError(f"paths must be among {', '.join(PATHS)} and include D, got {', '.join(only_paths)}")
    rng = np.random.default_rng(sc.seed + 7919)
    x = np.zeros(beacon.n_samples)
    for k in range(len(t_emit)):
        s = beacon.frame_samples(k)
        x[beacon.first_samples[k] : beacon.first_samples[k] + len(s)] += s
    xa = padded(hilbert(x))
    t_mid = t_emit + frame_s / 2
    direct_len = C * path_delay(sc, "D", t_mid)
    paths = (PATHS if echoes else ("D",)) if only_paths is None else tuple(p for p in PATHS if p in only_paths)
    gains = {}
    for p in paths:
        lens = C * path_delay(sc, p, t_mid)
        gains[p] = float(np.median([path_gain(sc, p, L, d) for L, d in zip(lens, direct_len)]))
    paths = [p for p in paths if p == "D" or abs(gains[p]) > 0.02]
    fading = {}
    if sc.fading:
        for p in paths:
            kdb = sc.fading["direct_k_db"] if p == "D" else sc.fading["k_db"]
            if math.isfinite(kdb):
                kk = 10 ** (kdb / 10)
                proc = _fading(rng, 24, sc.fading["spread_hz"])
                fading[p] = (math.sqrt(kk / (kk + 1)), math.sqrt(1 / (kk + 1)), proc)
    duration = float(t_emit[-1] + frame_s + direct_len.max() / C + 0.6)
    n = int(duration * fs)
    y = np.zeros(n)
    spans = []
    for k, te in enumerate(t_emit):
        t_a = reception_time(sc, te, "D") - 0.002
        t_b = max(reception_time(sc, te + frame_s, p) for p in paths) + 0.002
        i0, i1 = int(t_a * fs), min(int(t_b * fs) + 1, n)
        spans.append((i0, i1))
        for lo in range(i0, i1, chunk):
            t = np.arange(lo, min(lo + chunk, i1)) / fs
            acc = np.zeros(len(t), complex)
            for p in paths:
                tau = path_delay(sc, p, t)
                g = gains[p]
                if p in fading:
                    a, b, proc = fading[p]
                    g = g * (a + b * proc(t))
                acc += g * _interp(xa, fs, t - tau)
            y[lo : lo + len(t)] = acc.real
    # in-band signal power over the frames
    p_sig = np.mean([_band_power(y[a:b], fs, band) for a, b in spans])
    p_noise = p_sig / 10 ** (sc.snr_db / 10)
    frac_band = (band[1] - band[0]) / (fs / 2)
    sigma = math.sqrt(p_noise / frac_band)  # white of variance σ² puts σ²·B/(fs/2) in the band
    y += _noise(sc, rng, n, fs, sigma)
    truth = []
    for k, te in enumerate(t_emit):
        ta = reception_time(sc, te, "D")
        tb = reception_time(sc, te + frame_s, "D")
        d_rx = tb - ta
        info = []
        for p in paths:
            tp = reception_time(sc, te, p)
            tq = reception_time(sc, te + frame_s, p)
            info.append((p, tp - ta, C * (frame_s - (tq - tp)) / (tq - tp), gains[p]))
        truth.append(dict(t_arrival=ta, range=C * (ta - te), v_r=C * (frame_s - d_rx) / d_rx, paths=info))
    return Recording(sc, y, fs, t_emit, [f.payload for f in beacon.frames], truth, p_sig)


def _band_power(seg: np.ndarray, fs: float, band) -> float:
    """Mean power of seg inside the band (Parseval on its real FFT)."""
    spec = np.fft.rfft(seg)
    f = np.fft.rfftfreq(len(seg), 1 / fs)
    m = (f >= band[0]) & (f <= band[1])
    return float(2 * np.sum(np.abs(spec[m]) ** 2) / len(seg) ** 2)


def _noise(sc: Scenario, rng, n: int, fs: float, sigma: float) -> np.ndarray:
    """Noise whose Gaussian floor (or Gaussian-equivalent scale) is sigma."""
    kind = sc.noise.get("kind", "white")
    if kind == "white":
        return sigma * rng.standard_normal(n)
    if kind == "clicks":
        w = sigma * rng.standard_normal(n)
        n_clicks = rng.poisson(sc.noise["rate_hz"] * n / fs)
        at = rng.integers(0, n - 400, n_clicks)
        amp = sigma * 10 ** (sc.noise["level_db"] / 20) * rng.choice([-1, 1], n_clicks) * rng.uniform(0.5, 1.5, n_clicks)
        tt = np.arange(200) / fs
        for a0, k0 in zip(amp, at):
            f0 = rng.uniform(5e3, 40e3)
            w[k0 : k0 + 200] += a0 * np.exp(-tt / rng.uniform(5e-5, 3e-4)) * np.cos(2 * np.pi * f0 * tt)
        return w
    if kind == "gaussian_mixture":
        p, ratio = sc.noise["p"], 10 ** (sc.noise["ratio_db"] / 10)
        scale = np.where(rng.random(n) < p, math.sqrt(ratio), 1.0)
        return sigma * scale * rng.standard_normal(n)
    alpha = sc.noise["alpha"]
    v = rng.uniform(-np.pi / 2, np.pi / 2, n)
    e = rng.exponential(1.0, n)
    xs = np.sin(alpha * v) / np.cos(v) ** (1 / alpha) * (np.cos(v - alpha * v) / e) ** ((1 - alpha) / alpha)
    return sigma / math.sqrt(2) * xs  # α = 2 would give N(0, σ²)
