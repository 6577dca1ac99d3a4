"""A frame whose direct path is gone, its echo taken for it: the neighbours' track says so (``RecordLookahead``).

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


def _record(t, r, v, sigma_r=0.001, sigma_v=0.001):
    from seamodem.receive.records import MeasurementRecord

    return MeasurementRecord(frame_index=0, t_emit_s=t, t_arrival_s=t, tof_s=r / C, range_m=r, v_r_mps=v,
                             snr_db=15.0, v_r_tone_eq9_mps=v, v_r_bank_mps=v, detection_z=9.0, detection_rho=0.5,
                             sigma_range_m=sigma_r, sigma_v_r_mps=sigma_v, sigma_v_r_bank_mps=0.01,
                             tone_c_n0_dbhz=60.0)


def test_the_track_is_exact_for_a_constant_acceleration(monkeypatch):
    from seamodem.receive import frame
    from seamodem.receive.frame import track_gap_m2

    # r(t) = r0 − v0 t − a t²/2; a record's v_r is the mean over its frame, [t, t + D]: v0 + a(t + D/2)
    r0, v0, a, dur = 40.0, 0.4, 0.3, 0.3  # a: circling at 8 m, 1.6 m/s
    times = np.arange(5) * 1.0

    def rec(t, extra=0.0):
        return _record(t, r0 - v0 * t - a * t**2 / 2 + extra, v0 + a * (t + dur / 2))

    track = [rec(t) for t in np.delete(times, 2)]
    # no jerk allowed: the prediction itself must be exact (σ's of 1 mm)
    monkeypatch.setattr(frame, "TRACK_JERK_MPS3", 0.0)
    assert track_gap_m2(rec(2.0), track, sigma_range_m=0.001, half_frame_s=dur / 2) == 0.0
    # without bringing the speeds back to the arrivals, the same track is a·(D/2)·dt off (4.5 cm per second),
    # on opposite sides before and after: the last frame of a recording, its neighbours all before it, is
    before = track[:2]
    assert track_gap_m2(rec(2.0), before, sigma_range_m=0.001, half_frame_s=dur / 2) == 0.0
    assert track_gap_m2(rec(2.0), before, sigma_range_m=0.001, half_frame_s=0.0) > 0.03**2
    monkeypatch.undo()
    # with the jerk's allowance, a 50 cm error is found; the σ added is its gap less the farther
    # neighbours' 3σ (the jerk's over 2 s, 13 cm)
    d = track_gap_m2(rec(2.0, extra=0.5), track, sigma_range_m=0.001, half_frame_s=dur / 2) ** 0.5
    assert 0.25 < d < 0.5, d


def test_a_neighbour_that_is_itself_off_does_not_condemn_a_good_frame():
    from seamodem.receive.frame import track_gap_m2

    track = [_record(0.0, 100.0, 1.0), _record(1.0, 99.0 + 1.5, 1.0, sigma_r=1.5), _record(3.0, 97.0, 1.0),
             _record(4.0, 96.0, 1.0)]
    assert track_gap_m2(_record(2.0, 98.0, 1.0), track, sigma_range_m=0.001) == 0.0
    # nor do neighbours on both sides that disagree in opposite directions
    split = [_record(1.0, 99.5, 1.0), _record(3.0, 96.5, 1.0)]
    assert track_gap_m2(_record(2.0, 98.0, 1.0), split, sigma_range_m=0.001) == 0.0


def test_the_last_two_frames_on_an_echo_are_found_by_the_neighbours_that_can_tell():
    # corpus recording 5198852261 (fading): frames 8 and 9 of 10 took the surface echo, 1.0 m long; frame 8's
    # own check grew its σ to 0.53 m, and with it, it vetoed frame 9 (σ 48 mm, 20.9σ): it cannot tell a 1 m
    # gap, nor can frame 6, 3 s away (0.45 m of jerk allowed); frame 7 can, 2 s away, and is now enough
    from seamodem.receive.frame import track_gap_m2

    track = [_record(float(t), 100.0 - t, 1.0, sigma_r=0.01) for t in range(8)]
    track.append(_record(8.0, 100.0 - 8 + 1.0, 1.0, sigma_r=0.53))
    var = track_gap_m2(_record(9.0, 100.0 - 9 + 1.0, 1.0, sigma_r=0.048), track, sigma_range_m=0.048)
    assert 0.5 < var**0.5 < 1.0, var**0.5  # the gap less frame 7's 3 combined σ
    # a good last frame whose neighbour before is the one off: frame 7 can tell, and vetoes
    good = track[:8] + [_record(8.0, 100.0 - 8 + 1.0, 1.0, sigma_r=0.01)]
    assert track_gap_m2(_record(9.0, 91.0, 1.0, sigma_r=0.01), good, sigma_range_m=0.01) == 0.0
    # one neighbour that flags and none other that could tell: either may be off, the σ covers the gap
    alone = [_record(7.0, 93.0 + 1.0, 1.0, sigma_r=0.01), _record(3.0, 97.0, 1.0, sigma_r=0.5)]
    assert track_gap_m2(_record(9.0, 91.0, 1.0, sigma_r=0.01), alone, sigma_range_m=0.01) > 0.5**2
