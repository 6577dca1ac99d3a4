"""Two-way travel-time ranging without clock synchronisation (paper 004 §III.B).

The vehicle emits a poll at t_poll (its own clock); the beacon answers after a
known turnaround delay; the vehicle hears the reply's frame start at t_reply.
Only the vehicle's clock is used, so no offset between the clocks enters:

    d = c · (t_reply − t_poll − turnaround) / 2.

The :class:`~seamodem.receive.Receiver` applies this when given
``turnaround_s`` (its emissions are then the polls).
"""

from __future__ import annotations

import numpy as np

__all__ = ["two_way_range_m"]


def two_way_range_m(t_poll_s, t_reply_s, *, turnaround_s: float, sound_speed_mps: float):
    """Slant range from one poll/reply exchange [m].

    Parameters
    ----------
    t_poll_s : array_like
        Emission time of the vehicle's poll [s].
    t_reply_s : array_like
        Reception time of the reply's frame start [s], same clock.
    turnaround_s : float
        Beacon's delay from hearing the poll to emitting the reply [s].
    sound_speed_mps : float
        c [m/s].

    Notes
    -----
    Paper 004 §III.B: RTT = t_reply − t_poll, d = c (RTT − turnaround)/2.
    """
    return sound_speed_mps * (np.asarray(t_reply_s, float) - np.asarray(t_poll_s, float) - turnaround_s) / 2
