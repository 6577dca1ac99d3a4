"""Every channel through the receiver's front end, impulses blanked as found on the reference channel."""

from __future__ import annotations

import numpy as np

from ...config import FrameConfig
from ..frame import receiver_front_end
from ..frontend import FrontEnd
from ..settings import ReceiverSettings


#: the reference channel goes through the impulse blanker in blocks of this many samples
BLANKER_BLOCK = 1 << 16


def _blanked_stretches(x: np.ndarray, blanked_reference: np.ndarray, reference_channel: int,
                       spread_samples: int) -> tuple[np.ndarray, np.ndarray]:
    """[start, stop) sample spans of the reference channel's blanked samples widened by ``spread_samples``."""
    hit = np.flatnonzero((blanked_reference == 0.0) & (x[:, reference_channel] != 0.0))
    if not hit.size:
        return hit, hit
    s = max(int(spread_samples), 0)
    new_run = np.flatnonzero(np.diff(hit) > 2 * s + 1) + 1  # widened stretches that do not touch the previous one
    starts = np.maximum(hit[np.concatenate([[0], new_run])] - s, 0)
    stops = np.minimum(hit[np.concatenate([new_run - 1, [hit.size - 1]])] + s + 1, x.shape[0])
    return starts, stops


def blank_like_reference(x: np.ndarray, blanked_reference: np.ndarray, reference_channel: int,
                         spread_samples: int) -> np.ndarray:
    """x with every channel zeroed where the reference channel was blanked, widened by ``spread_samples``.

    A click reaches elements a few centimetres apart within aperture/c of each
    other (5 samples for 8 cm at 96 kHz): the reference channel's blanked
    stretches, widened by that much on either side, cover it on every element.

    Parameters
    ----------
    x : numpy.ndarray, shape (n_samples, n_channels)
        Real passband channels.
    blanked_reference : numpy.ndarray, shape (n_samples,)
        The reference channel after the impulse blanker (zeros where blanked).
    reference_channel : int
        Its column in ``x``.
    spread_samples : int
        Widening of each blanked stretch on either side [samples].

    Returns
    -------
    numpy.ndarray, shape (n_samples, n_channels)
        A blanked copy (``x`` itself when nothing was blanked).
    """
    starts, stops = _blanked_stretches(x, blanked_reference, reference_channel, spread_samples)
    if not starts.size:
        return x
    out = np.array(x, float)
    for a, b in zip(starts, stops):
        out[a:b] = 0.0
    return out


def front_end_array(x: np.ndarray, fs: float, config: FrameConfig, settings: ReceiverSettings,
                    reference_channel: int = 0, spread_samples: int = 8):
    """Basebands of every channel through the receiver's front end.

    Impulses are found on the reference channel and zeroed on every channel
    (:func:`blank_like_reference`, ``spread_samples`` either side): one
    blanker's cost, not K.

    Parameters
    ----------
    x : numpy.ndarray, shape (n_samples, n_channels)
        Real passband channels.
    fs : float
        Their sample rate [Hz].
    config : FrameConfig
        The transmitted frame (its bands).
    settings : ReceiverSettings
        v_max, sound speed and impulse blanking (:func:`~seamodem.receive.frame.receiver_front_end`).
    reference_channel : int
        The channel the impulse blanker runs on.
    spread_samples : int
        Widening of its blanked stretches on the other channels [samples].

    Returns
    -------
    plan : FrontEndPlan
        The front end (rates [Hz], bands).
    bb : numpy.ndarray, shape (n, n_channels), complex
        Data-band basebands.
    tone : numpy.ndarray, shape (n_tone, n_channels), complex
        Tone basebands.
    blanker : ImpulseBlanker or None
        The reference channel's blanker (None without blanking).
    """
    plan, blanker = receiver_front_end(config, fs, settings)
    stretches = (np.zeros(0, int), np.zeros(0, int))
    if blanker is not None:
        ref = x[:, reference_channel]
        # in blocks, as the streaming receiver feeds it: the blanker's envelope pass runs only on the blocks
        # that hold an impulse (one push of the whole recording ran it over every sample: 0.2 s per 31 s)
        y0 = np.concatenate([*(blanker.push(ref[i:i + BLANKER_BLOCK]) for i in range(0, len(ref), BLANKER_BLOCK)),
                             blanker.flush()])
        if blanker.n_blanked:
            stretches = _blanked_stretches(x, y0, reference_channel, spread_samples)
    bbs, tones = [], []
    for k in range(x.shape[1]):
        fe = FrontEnd(plan)
        xk = np.array(x[:, k], float)  # contiguous (the front end copies it anyway)
        for i0, i1 in zip(*stretches):
            xk[i0:i1] = 0.0
        a, b = fe.push(xk)
        c, d = fe.flush()
        bbs.append(np.concatenate([a, c]))
        tones.append(np.concatenate([b, d]))
    return plan, np.stack(bbs, axis=1), np.stack(tones, axis=1), blanker
