"""The ends' depths from the echoes a whole-frame fit resolves: the surface image merged with the direct path.

Far from the beacon, in shallow water, the surface image comes δ = 2·z_b·z_v/(R·c) after the direct path,
below the signal's resolution 1/B: the two merge, and the arrival is biased by about half of δ (a surface
reflection −0.8…−0.98). The frame cannot show it, its channel bend second order in δ. The ends' depths give
δ (``FrameMeasurer.merged_image``); without them, the echoes the fit does resolve give the geometry.

In a flat waveguide of depth H (method of images, the paraxial lags (d² − d₀²)/(2·c·R) of an image whose
vertical distance to the receiver is d, d₀ = z_b − z_v the direct path's), the first three echoes after the
merged pair are the bottom image B, d = 2H − (z_b + z_v), and the two surface–bottom images,
d = 2H ∓ d₀. With u = z_b + z_v and s = 2·c·R:

- τ_SB + τ_BS = 8H²/s gives H;
- τ_BS − τ_SB = 8H·|d₀|/s gives |d₀|;
- τ_B = ((2H − u)² − d₀²)/s gives u;

and δ = (u² − d₀²)/s, independent of s: the three lags alone set it (the range only sets the depths'
scale). The lags a fit measures are after the merged pair's arrival, itself about Re(w)·δ late: the caller
adds that back (:func:`depths_from_echoes`'s ``lead_s``).

An echo pattern this does not explain is not used: the surface–bottom images' gains must be those of the
bottom image less one surface bounce (≤ 20 %; this also tells the pattern from its mirror image, both ends
near the bottom, whose pair is weaker than its first echo by the bottom's loss), the geometry physical (0 < z < H), the image merged (δ < 1/B),
and every other echo the fit holds with a tenth of the first path's gain or more must lie where an image of
the first two orders does. A steep channel whose surface image is resolved has that image as its first echo,
and its three first echoes do not form this pattern.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ..config import FrameConfig

__all__ = ["ImageDepths", "GEOMETRY_MIN_GAIN", "depths_from_echoes", "pooled_depths", "image_lags_s"]

#: echoes at least this share of the first path's gain are the pattern's (the fit's weak paths, 0.01–0.05 of
#: it in the corpus's far family, are its noise)
GEOMETRY_MIN_GAIN = 0.1
#: the surface–bottom images' gains over the bottom image's (the first echo's): one surface bounce more,
#: ρ 0.8–0.98 at grazing; resolved, each within these, and as one echo (the two adding or cancelling)
#: within the second pair. The waveguide's mirror image (both ends near the bottom: a merged bottom image,
#: the surface image first, the pairs one bottom bounce more) gives the same lags and the same δ, but its
#: pair is weaker than its first echo by the bottom's loss: corpus fading 1887576187, a bottom image 0.47
#: at 38 µs merged, its pair 0.3–0.56 of the surface echo's gain
_PAIR_RATIO, _MERGED_PAIR_RATIO = (0.6, 1.5), (0.4, 2.2)
#: an echo is an image's when within this share of 1/B of its lag
_MATCH_B = 0.5
#: an image of a merged surface image's geometry travels nearly parallel to the direct path (grazing: sin θ of
#: the first images ≈ 2H/R ≤ 0.07 in the corpus's far family): its Doppler within this of the direct path's
#: [m/s], beyond three of the fit's σ (the far family's echoes: 0–0.03 m/s; the steep family's, circling
#: 8–15 m from the beacon: 0.07–0.5 m/s at the 5th–75th percentiles)
GRAZING_DOPPLER_MPS = 0.05


def grazing(doppler_gaps_mps, sigma_v_mps) -> np.ndarray:
    """Which echoes travel parallel to the direct path: their Doppler less its (``doppler_gaps_mps`` [m/s])
    within :data:`GRAZING_DOPPLER_MPS` and three of its σ (``sigma_v_mps``). An echo whose Doppler or σ is
    NaN (not measured) is not: nothing shows that it grazes (the one test of :func:`depths_from_echoes` and
    ``frame.thin_waveguide``).

    >>> grazing([0.01, -0.2, float("nan")], [0.01, 0.01, 0.01]).tolist()
    [True, False, False]
    """
    gaps = np.abs(np.asarray(doppler_gaps_mps, float))
    with np.errstate(invalid="ignore"):
        return gaps <= GRAZING_DOPPLER_MPS + 3 * np.asarray(sigma_v_mps, float)


#: the farthest of the three images' vertical distance (2H + |z_b − z_v|) at most this share of the range: the
#: paraxial lags within 2 % (a steep channel's first echoes, 8–10 ms behind at 11 m, are no such images)
_PARAXIAL = 0.3
#: a fitted lag's σ at least this share of 1/B (the fit's own σ leaves out a neighbour's pull)
_LAG_FLOOR_B = 0.03


class ImageDepths(NamedTuple):
    """The geometry the echoes give (:func:`depths_from_echoes`, :func:`pooled_depths`) [m]."""

    #: the two ends' depths (which is which is not known; the surface image does not depend on it)
    z1_m: float
    z2_m: float
    #: the water's depth
    water_depth_m: float
    #: σ of the depths (their scatter over the frames pooled, at least a floor)
    sigma_m: float = 0.0
    #: σ of the surface image's delay the lags' σ give [s] (two merged surface–bottom images: their unknown
    #: split too)
    delay_sigma_s: float = 0.0


def image_lags_s(z1_m: float, z2_m: float, water_depth_m: float, range_m: float, sound_speed_mps: float,
                 *, orders: int = 2) -> np.ndarray:
    """Paraxial lags after the direct path [s] of the images of the first ``orders`` orders (source images
    2kH ± z₁, |k| ≤ orders), sorted, the direct path's (0) left out."""
    s = 2 * sound_speed_mps * range_m
    d0 = z1_m - z2_m
    lags = []
    for k in range(-orders, orders + 1):
        for sign in (1.0, -1.0):
            if k == 0 and sign > 0:
                continue
            d = 2 * k * water_depth_m + sign * z1_m - z2_m
            lags.append((d * d - d0 * d0) / s)
    return np.sort(np.asarray(lags))


def _solve(a: float, b: float, e: float, s: float) -> tuple[float, float, float, float] | None:
    """(z₁, z₂, H, δ·s) from the lags of B and of the two surface–bottom images (s = 2cR), or None."""
    if not (b + e > 0):
        return None
    h = math.sqrt(s * (b + e) / 8)
    d0 = s * abs(e - b) / (8 * h)
    inner = s * a + d0 * d0
    if not inner > 0:
        return None
    u = 2 * h - math.sqrt(inner)
    z1, z2 = (u + d0) / 2, (u - d0) / 2
    if not (0 < z2 <= z1 < h):
        return None
    return z1, z2, h, u * u - d0 * d0


def depths_from_echoes(lags_s, gains, range_m: float, *, config: FrameConfig, sound_speed_mps: float,
                       lead_s: float = 0.0, doppler_gaps_mps=None, sigma_v_mps=None,
                       sigma_lags_s=None) -> ImageDepths | None:
    """The ends' depths and the water's from one fit's echoes (lags after its first path [s], gains relative
    to it: ``frame.fit_echoes``), at the slant range ``range_m``; None when the echoes do not form the
    pattern of a merged surface image (the module's docstring). ``lead_s``: how late the fit's first path is
    on the direct path (the merged image's bias), added to every lag. ``doppler_gaps_mps``, ``sigma_v_mps``:
    each echo's Doppler less the first path's and its σ [m/s] (a pattern echo beyond
    :data:`GRAZING_DOPPLER_MPS` and three σ of it, or NaN, is not grazing: :func:`grazing`); ``sigma_lags_s``:
    the lags' σ [s].

    Where the two surface–bottom images are within 1/B of each other (the ends' depths within
    s/(8H·B) of each other) the fit holds one echo for both, at about their mean lag: their split is
    then anywhere from 0 to 1/B, and its spread goes to the image's delay σ.

    >>> from seamodem import get_preset
    >>> cfg = get_preset("jmse2024")
    >>> lags = image_lags_s(3.0, 4.0, 15.0, 800.0, 1500.0, orders=1)  # S, B, SB, BS, SBS
    >>> g = depths_from_echoes(lags[1:4], [0.6, 0.55, 0.55], 800.0, config=cfg, sound_speed_mps=1500.0)
    >>> round(g.z1_m, 2), round(g.z2_m, 2), round(g.water_depth_m, 2)
    (4.0, 3.0, 15.0)
    """
    lags = np.asarray(lags_s, float)
    gains = np.asarray(gains, float)
    n = lags.size
    gaps = np.zeros(n) if doppler_gaps_mps is None else np.asarray(doppler_gaps_mps, float)
    sig_v = np.zeros(n) if sigma_v_mps is None else np.asarray(sigma_v_mps, float)
    one_b = 1.0 / config.bandwidth_hz
    sig_lag = np.full(n, _LAG_FLOOR_B * one_b) if sigma_lags_s is None else np.maximum(
        np.asarray(sigma_lags_s, float), _LAG_FLOOR_B * one_b)
    if n < 2 or not (math.isfinite(range_m) and range_m > 0):
        return None
    if np.any((gains >= GEOMETRY_MIN_GAIN) & (lags > 0) & (lags < one_b)):
        return None  # a path within the pulse's width: not a merged pair alone
    strong = np.flatnonzero(_strong(lags, gains, one_b))
    strong = strong[np.argsort(lags[strong])]
    if strong.size < 2:
        return None
    s = 2 * sound_speed_mps * range_m

    def attempt(idx, merged: bool):
        lg = lags[idx] + lead_s
        low, high = _MERGED_PAIR_RATIO if merged else _PAIR_RATIO
        ratios = gains[idx[1:]] / gains[idx[0]]
        if np.any(ratios < low) or np.any(ratios > high):
            return None
        if not np.all(grazing(gaps[idx], sig_v[idx])):
            return None
        if merged:
            a, m = lg
            # the split e − b from 0 to 1/B: b, e = m ∓ split/2
            # (the lags' σ below is differenced from the split whose solution is the middle one: when some
            # splits do not solve, that is not the middle split)
            tried = [(x, _solve(a, m - x / 2, m + x / 2, s)) for x in np.linspace(0.0, one_b, 5)]
            solved = [(x, sol) for x, sol in tried if sol is not None]
            if not solved:
                return None
            deltas = np.array([sol[3] for _, sol in solved]) / s
            split, mid = solved[len(solved) // 2]
            spread = float(np.ptp(deltas)) / 2
            base = (a, m - split / 2, m + split / 2)
        else:
            mid = _solve(*lg, s)
            if mid is None:
                return None
            spread, base = 0.0, tuple(lg)
        z1, z2, h, ds = mid
        delta = ds / s
        if not delta < one_b:
            return None
        if 2 * h + (z1 - z2) > _PARAXIAL * range_m:
            return None  # the images not at grazing angles: the lags are not these (nor the Doppler alike)
        # the lags' σ, through the solution (a one-sided difference of each)
        var = spread**2
        for k, i in enumerate(idx):
            moved = list(base)
            step = float(sig_lag[i])
            if merged and k == 1:
                moved[1] += step
                moved[2] += step
            else:
                moved[k] += step
            got = _solve(*moved, s)
            var += ((got[3] / s - delta) if got is not None else one_b) ** 2
        # every other strong echo where an image of the first two orders lies
        predicted = image_lags_s(z1, z2, h, range_m, sound_speed_mps)
        rest = lags[[i for i in strong if i not in set(idx)]] + lead_s
        if merged and np.any(np.abs(rest - lg[1]) < 1.5 * one_b):
            return None  # the two surface–bottom images resolved after all: not one echo for both
        if rest.size and np.any(np.min(np.abs(rest[:, None] - predicted[None, :]), axis=1) > _MATCH_B * one_b):
            return None
        return ImageDepths(float(z1), float(z2), float(h), 0.0, math.sqrt(var))

    found = attempt(strong[:3], False) if strong.size >= 3 else None
    return found if found is not None else attempt(strong[:2], True)


def _strong(lags: np.ndarray, gains: np.ndarray, one_b: float) -> np.ndarray:
    """Which echoes are the pattern's candidates: a tenth of the first path's gain or more, 1/B or more behind it."""
    return (gains >= GEOMETRY_MIN_GAIN) & (lags >= one_b)


def _n_strong(echoes, one_b: float) -> int:
    return int(np.count_nonzero(_strong(np.asarray(echoes[0], float), np.asarray(echoes[1], float), one_b)))


def pooled_depths(pool, range_m: float, *, config: FrameConfig, sound_speed_mps: float, lead_s=None,
                  min_frames: int = 1, floor_m: float = 0.1) -> ImageDepths | None:
    """The depths over recent frames' echoes ``pool`` (per frame, ``frame.fit_echoes``'s lags and gains, then
    optionally the echoes' Doppler gaps, their σ and the lags' σ, as :func:`depths_from_echoes` takes them):
    the median of the frames whose echoes give them (:func:`depths_from_echoes`), with their scatter as the
    σ (at least ``floor_m``); None unless at least ``min_frames`` give them and no fewer than the frames
    whose two or more echoes do not form the pattern (a frame whose fit merged the images into one echo
    or missed them shows none: it does not count against the others).
    ``lead_s``: a function of the depths giving the merged pair's lateness on the direct path (iterated
    twice from none), or None."""
    pool = list(pool)
    if not pool:
        return None
    one_b = 1.0 / config.bandwidth_hz
    lead = 0.0
    found = None
    for _ in range(3 if lead_s is not None else 1):
        got = [depths_from_echoes(*echoes[:2], range_m, config=config, sound_speed_mps=sound_speed_mps,
                                  lead_s=lead, **dict(zip(("doppler_gaps_mps", "sigma_v_mps", "sigma_lags_s"),
                                                          echoes[2:]))) for echoes in pool]
        # a frame whose fit holds two or more echoes with a tenth of the first path's gain, 1/B or more behind
        # it, and no pattern speaks against it (one that merged or missed them says nothing)
        against = sum(g is None and _n_strong(echoes, one_b) >= 2 for g, echoes in zip(got, pool))
        got = [g for g in got if g is not None]
        if len(got) < max(min_frames, against):
            return None
        arr = np.array([[g.z1_m, g.z2_m, g.water_depth_m] for g in got])
        z = np.median(arr, axis=0)
        spread = float(np.max(np.std(arr[:, :2], axis=0))) if len(got) > 1 else 0.0
        found = ImageDepths(float(z[0]), float(z[1]), float(z[2]), max(floor_m, spread),
                            float(np.median([g.delay_sigma_s for g in got])))
        if lead_s is not None:
            lead = float(lead_s(found))
    return found
