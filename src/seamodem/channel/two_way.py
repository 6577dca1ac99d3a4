"""Two-way ranging exchanges: the vehicle polls, the beacon replies (paper 004 §III.B).

With a ``[two_way]`` table, the input recording's frames are the beacon's
replies. Exchange k, all on true (beacon) time unless said otherwise:

1. the vehicle emits poll k at t_p = clock.to_true(t_poll,rx), t_poll,rx being
   the poll time on the vehicle's own clock (the scenario's [clock]);
2. the beacon, still, hears it at t_h = t_p + τ_0(t_p): the direct path's delay
   for a reception at t is |r(t) − b|/c with the vehicle at r(t), and by
   reciprocity a wave emitted by the vehicle at t_p reaches the still beacon
   after the same |r(t_p) − b|/c (profile mode: c·τ_0(t) is the range too);
3. the beacon emits its reply, input frame k, at t_e = t_h + turnaround
   (an ideal beacon: it detects the poll exactly, and its clock is true time);
4. the reply travels back through the scenario's channel as any frame does,
   and the vehicle hears its frame start at t_a (truth: t_a − τ_0(t_a) = t_e).

The vehicle measures RTT = t_a,rx − t_poll,rx = (1 + ppm·1e-6)(t_a − t_p): its
clock offset cancels. ``seamodem rx --turnaround T`` then reports
d = c (RTT − T)/2 = (R_out + R_back)/2 without clock error, the mean of the
outbound range R_out = c τ_0(t_p) (at the poll) and the return range
R_back = c (t_a − t_e) (at the reply's reception): the truth of a two-way
range for a moving vehicle.

The poll's own waveform is not in the recording (the vehicle's receiver is
blanked while it transmits, or the poll uses another band): only the replies are.

The beacon's emitted signal is the input re-timed frame by frame: frame k
(input samples over [t_in,k, t_in,k + T_F)) is shifted by t_e,k − t_in,k with
the channel's band-limited interpolator (:class:`RetimedInput`).
"""

from __future__ import annotations

import numpy as np

from ..errors import ConfigError
from .model import ChannelModel
from .resample import HALF_TAPS, render_paths

__all__ = ["ReplySchedule", "reply_schedule", "RetimedInput", "two_way_truth"]


class ReplySchedule:
    """Times of each exchange (module docstring), arrays of shape (n_frames,).

    Attributes
    ----------
    t_poll_s : poll emission on the vehicle's clock [s]
    t_poll_true_s : the same on true time [s]
    t_poll_heard_s : the beacon hears the poll (true time) [s]
    t_reply_emit_s : the beacon emits the reply's frame start (true time) [s]
    range_poll_m : outbound range R_out = c τ_0(t_p) [m]
    turnaround_s : float
    """

    def __init__(self, t_poll_s, t_poll_true_s, t_poll_heard_s, t_reply_emit_s, range_poll_m, turnaround_s):
        self.t_poll_s = t_poll_s
        self.t_poll_true_s = t_poll_true_s
        self.t_poll_heard_s = t_poll_heard_s
        self.t_reply_emit_s = t_reply_emit_s
        self.range_poll_m = range_poll_m
        self.turnaround_s = float(turnaround_s)

    def to_dict(self) -> dict:
        return {
            "turnaround_s": self.turnaround_s,
            "t_poll_s": self.t_poll_s.tolist(),
            "t_poll_true_s": self.t_poll_true_s.tolist(),
            "t_poll_heard_s": self.t_poll_heard_s.tolist(),
            "t_reply_emit_s": self.t_reply_emit_s.tolist(),
            "range_poll_m": self.range_poll_m.tolist(),
            "definition": (
                "vehicle polls at t_poll_s (its clock); the beacon hears it at t_poll_heard_s = t_p + |r(t_p) - b|/c "
                "and emits input frame k at t_reply_emit_s = t_poll_heard_s + turnaround_s (true time)"
            ),
        }


def reply_schedule(model: ChannelModel, t_poll_s, *, turnaround_s: float, frame_duration_s: float) -> ReplySchedule:
    """When the beacon replies to each poll (module docstring, steps 1–3).

    Parameters
    ----------
    model : ChannelModel
        The scenario's channel; its direct path (index 0) carries the poll.
    t_poll_s : array_like
        Poll emission times on the vehicle's clock [s], increasing.
    turnaround_s : float
        Beacon's delay from hearing a poll to emitting its reply [s].
    frame_duration_s : float
        T_F [s]: consecutive replies must not overlap.

    Raises
    ------
    ConfigError
        Replies that would overlap (polls closer than a frame), or a reply
        emitted before true time 0.
    """
    t_rx = np.asarray(t_poll_s, dtype=float).reshape(-1)
    t_p = np.asarray(model.clock.to_true(t_rx), dtype=float)
    tau = model.delays(t_p)[0]
    t_h = t_p + tau
    t_e = t_h + turnaround_s
    gaps = np.diff(t_e)
    if gaps.size and np.min(gaps) < frame_duration_s:
        k = int(np.argmin(gaps))
        raise ConfigError("two_way.poll_period_s",
                          f"replies {k} and {k + 1} would overlap: emitted {gaps[k]:.6g} s apart, "
                          f"less than the frame duration {frame_duration_s:.6g} s")
    if t_e[0] < 0:
        raise ConfigError("two_way.first_poll_s",
                          f"the first reply would be emitted at true time {t_e[0]:.6g} s < 0 (the poll at "
                          f"{t_rx[0]:g} s on the vehicle's clock is true time {t_p[0]:.6g} s, with clock.offset_s)")
    return ReplySchedule(t_rx, t_p, t_h, t_e, model.c * tau, turnaround_s)


class RetimedInput:
    """The beacon's emission: each input frame moved to its reply time (a readable source).

    Frame k occupies input samples [⌈t_in,k·fs⌉, ⌈(t_in,k + T_F)·fs⌉) (zero
    outside); emission sample n holds that frame at input position
    n − (t_out,k − t_in,k)·fs, band-limited (the channel's 32-tap interpolator).
    ``source`` has ``n`` and ``read(lo, hi)`` (as the simulator's inputs);
    this object has the same, so the simulator reads it as its input.

    Parameters
    ----------
    source : object
        The input, with ``n`` (its length in samples) and ``read(lo, hi)``.
    fs : float
        Sample rate [Hz].
    t_in_s : array_like
        Start of each frame in the input [s], shape ``(n_frames,)``.
    t_out_s : array_like
        Emission time of each frame (its reply) [s], shape ``(n_frames,)``.
    frame_duration_s : float
        Duration T_F of one frame [s].

    Attributes
    ----------
    n : int
        Length of the emission [samples], up to the last frame's end plus the
        interpolator's margin.
    """

    def __init__(self, source, fs: float, t_in_s, t_out_s, frame_duration_s: float):
        self.source = source
        self.fs = float(fs)
        t_in = np.asarray(t_in_s, dtype=float)
        t_out = np.asarray(t_out_s, dtype=float)
        self.i0 = np.ceil(t_in * fs - 1e-9).astype(np.int64)
        self.i1 = np.minimum(np.ceil((t_in + frame_duration_s) * fs - 1e-9).astype(np.int64), source.n)
        self.shift = (t_out - t_in) * fs  # emission sample − input sample
        pad = HALF_TAPS + 2
        self.a = np.floor(self.i0 + self.shift).astype(np.int64) - pad
        self.b = np.ceil(self.i1 + self.shift).astype(np.int64) + pad
        self.n = int(max(self.b.max(), 1))

    def read(self, lo: int, hi: int) -> np.ndarray:
        """Emission samples ``lo`` to ``hi`` (excluded).

        Parameters
        ----------
        lo, hi : int
            Sample range [samples].

        Returns
        -------
        numpy.ndarray
            Samples, shape ``(hi - lo,)``, zero between frames.
        """
        out = np.zeros(hi - lo)
        for k in np.flatnonzero((self.a < hi) & (self.b > lo)):
            n_lo, n_hi = max(lo, int(self.a[k])), min(hi, int(self.b[k]))
            pos = np.arange(n_lo, n_hi) - self.shift[k]
            pad = 3 * (HALF_TAPS + 2)  # input_span of pos reaches HALF_TAPS + 2 beyond [a, b)
            x_lo = int(self.i0[k]) - pad
            x = np.zeros(int(self.i1[k] - self.i0[k]) + 2 * pad)
            x[pad : pad + self.i1[k] - self.i0[k]] = self.source.read(int(self.i0[k]), int(self.i1[k]))
            render_paths(x, x_lo, pos[None, :], np.ones((1, pos.size)), out=out[n_lo - lo : n_hi - lo])
        return out


def two_way_truth(rows: list[dict], schedule: ReplySchedule, sound_speed_mps: float) -> list[dict]:
    """Turn the replies' one-way truth into two-way truth, in place (module docstring).

    The SPEC columns become what ``seamodem rx --turnaround`` measures:
    ``t_emit_s`` = the poll (vehicle clock), ``tof_s`` = (t_arrival_s −
    t_poll − turnaround)/2, ``range_m`` = c·tof_s. Their ``_true`` twins are
    the physical values: ``tof_true_s`` = (t_a − t_p − turnaround)/2 and
    ``range_true_m`` = (range_poll_m + range_reply_m)/2. Added: ``two_way``,
    ``turnaround_s``, ``t_poll_true_s``, ``t_poll_heard_s``, ``t_reply_emit_s``,
    ``range_poll_m`` (R_out, at the poll) and ``range_reply_m`` (R_back, at the
    reply's reception). ``v_r_mps`` stays the reply's (return path) closing speed;
    ``paths`` stay one-way, from the reply's emission.

    Parameters
    ----------
    rows : list of dict
        One-way truth rows of the replies, one per poll, with
        ``t_arrival_s`` and ``t_arrival_true_s`` [s].
    schedule : ReplySchedule
        Poll and reply times of the same replies.
    sound_speed_mps : float
        Sound speed c [m/s].

    Returns
    -------
    list of dict
        ``rows``, updated.
    """
    c = sound_speed_mps
    T = schedule.turnaround_s
    for k, row in enumerate(rows):
        t_poll, t_p = float(schedule.t_poll_s[k]), float(schedule.t_poll_true_s[k])
        t_e = float(schedule.t_reply_emit_s[k])
        range_reply = c * (row["t_arrival_true_s"] - t_e)
        tof = (row["t_arrival_s"] - t_poll - T) / 2
        tof_true = (row["t_arrival_true_s"] - t_p - T) / 2
        row.update(
            t_emit_s=t_poll,
            tof_s=tof,
            range_m=c * tof,
            tof_true_s=tof_true,
            range_true_m=c * tof_true,
            two_way=True,
            turnaround_s=T,
            t_poll_true_s=t_p,
            t_poll_heard_s=float(schedule.t_poll_heard_s[k]),
            t_reply_emit_s=t_e,
            range_poll_m=float(schedule.range_poll_m[k]),
            range_reply_m=range_reply,
        )
    return rows
