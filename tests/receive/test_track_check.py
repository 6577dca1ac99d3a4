"""A frame whose direct path is gone, its echo taken for it: the neighbours' track says so (``ShapeLookahead``).

One frame of eight has no direct path (faded out, shadowed): the only arrival is an echo 0.8 ms behind,
which the pilot takes as the direct path, 1.2 m long with the σ of a clean frame (mm). Nothing in the
frame shows it. Its neighbours' ranges and closing speeds put it 1.2 m off their track, which the record's
σ then covers (a file's records wait for 5 more frames); a live receiver (no look-ahead) cannot. Analytic
frames (tests/receive/analytic.py), nothing from the project's channel code.
"""

from __future__ import annotations

import numpy as np
import pytest

from seamodem import get_preset
from seamodem.receive import Emissions, Receiver, ReceiverSettings
from seamodem.transmit.frame import build_frame

from analytic import awgn_sigma, received_frame

CFG = get_preset("jmse2024")
FS = CFG.sample_rate_hz
C = 1500.0
V = 0.8  # closing [m/s]
ECHO_S = 0.8e-3
LOST = 4  # the frame without its direct path


def _records(lookahead: int, seed: int = 31):
    rng = np.random.default_rng(seed)
    n = 8
    payloads = [f"track {k}".encode() for k in range(n)]
    t_emit = 0.1 + np.arange(n) * 1.0
    t = np.arange(int((n + 0.6) * FS)) / FS
    x = np.zeros(t.size)
    tof = np.empty(n)
    for k in range(n):
        # a closing track: the range shrinks by V per second (the arrival's tof at emission k)
        tof[k] = (300.0 - V * t_emit[k]) / (C + V)
        frame = build_frame(CFG, payloads[k])
        for delay, gain in ([(ECHO_S, 0.6)] if k == LOST else [(0.0, 1.0), (ECHO_S, 0.6)]):
            x += received_frame(frame, t, t_arrival_s=t_emit[k] + tof[k] + delay, v_mps=V, gain=gain)
    x += awgn_sigma(CFG, 18.0) * rng.standard_normal(t.size)
    rx = Receiver(CFG, emissions=Emissions(times_s=t_emit), settings=ReceiverSettings(decode=True,
                  lookahead_frames=lookahead), payloads=payloads)
    records = {r.frame_index: r for r in rx.run([x], fs=FS)}
    assert sorted(records) == list(range(n))
    return records, tof


@pytest.mark.parametrize("lookahead", [0, 5])
def test_an_echo_taken_for_the_direct_path_is_covered_by_the_track(lookahead):
    records, tof = _records(lookahead)
    z = {k: (r.range_m - C * tof[k]) / r.sigma_range_m for k, r in records.items()}
    err = records[LOST].range_m - C * tof[LOST]
    assert err == pytest.approx(C * ECHO_S, abs=0.1)  # the echo was taken: 1.2 m long
    others = [k for k in records if k != LOST]
    assert all(abs(z[k]) <= 3 for k in others), z
    # and the other frames keep a clean frame's σ: the lost one does not condemn its neighbours
    assert all(records[k].sigma_range_m < 0.01 for k in others), [records[k].sigma_range_m for k in others]
    if lookahead:
        assert abs(z[LOST]) <= 3, z
        assert records[LOST].sigma_range_m <= 2 * abs(err), records[LOST].sigma_range_m  # its scale, not more
    else:
        assert abs(z[LOST]) > 30, z  # live: nothing to compare with yet
