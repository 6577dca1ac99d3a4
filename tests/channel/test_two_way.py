"""[two_way]: polls, the beacon's replies re-timed by the channel, and the two-way truth."""

import numpy as np
import pytest

from seamodem.channel import parse_scenario, simulate
from seamodem.errors import ConfigError

C = 1500.0
FS = 96000.0
BEACON = np.array([10.0, -20.0, -8.0])
START = np.array([-150.0, 60.0, -4.0])
VELOCITY = np.array([2.0, -0.6, -0.05])
T_F = 0.3  # frame duration [s]
T_IN = np.array([0.1, 0.5, 0.9])  # the input's frame starts [s]
TURNAROUND = 0.25


def geometry(**two_way):
    return {
        "mode": "geometry",
        "environment": {"sound_speed_mps": C, "water_depth_m": 25.0},
        "beacon": {"position_m": BEACON.tolist()},
        "vehicle": {"start_m": START.tolist(), "velocity_mps": VELOCITY.tolist()},
        "multipath": {"max_bounces": 0},
        "two_way": {"turnaround_s": TURNAROUND, **two_way},
    }


def return_arrival(te):
    """Independent closed form: |d0 + v t| = c (t − te) for a still beacon, d0 = start − beacon."""
    d0 = START - BEACON
    roots = np.roots([VELOCITY @ VELOCITY - C**2, 2 * (d0 @ VELOCITY + C**2 * te), d0 @ d0 - C**2 * te**2])
    return float(max(r.real for r in roots if r.real > te))


def burst(t):
    """A Gaussian-windowed 20 kHz burst 0.15 s into each input frame (the 'frame')."""
    out = np.zeros_like(t)
    for t0 in T_IN:
        u = t - t0 - 0.15
        out += np.exp(-0.5 * (u / 0.01) ** 2) * np.cos(2 * np.pi * 20000.0 * u)
    return out


def run(data, x=None):
    n = round(1.3 * FS)
    x = np.zeros(n) if x is None else x
    return simulate(x, FS, parse_scenario(data), t_emit_s=T_IN, frame_duration_s=T_F, band_hz=(15000.0, 25000.0))


@pytest.mark.parametrize("offset,ppm", [(0.0, 0.0), (-2.5, 0.0), (-0.7, 30.0)])
def test_truth_against_closed_form_and_clock_offset_cancels(offset, ppm):
    data = geometry(first_poll_s=0.2, poll_period_s=0.8)
    data["clock"] = {"offset_s": offset, "sample_rate_offset_ppm": ppm}
    result = run(data)
    rate = 1 + 1e-6 * ppm
    for k, row in enumerate(result.truth):
        t_poll = 0.2 + 0.8 * k  # vehicle clock
        t_p = (t_poll - offset) / rate  # true time
        r_out = np.linalg.norm(START + VELOCITY * t_p - BEACON)  # still beacon: outbound = range at the poll
        t_e = t_p + r_out / C + TURNAROUND
        t_a = return_arrival(t_e)
        r_back = np.linalg.norm(START + VELOCITY * t_a - BEACON)
        assert row["t_emit_s"] == t_poll and row["two_way"] and row["turnaround_s"] == TURNAROUND
        assert row["t_reply_emit_s"] == pytest.approx(t_e, abs=1e-12)
        assert row["range_poll_m"] == pytest.approx(r_out, abs=1e-8)
        assert row["range_reply_m"] == pytest.approx(r_back, abs=1e-8)
        assert row["range_true_m"] == pytest.approx((r_out + r_back) / 2, abs=1e-8)
        # what the vehicle measures on its own clock: the offset cancels, the rate error does not
        assert row["t_arrival_s"] == pytest.approx(rate * t_a + offset, abs=1e-11)
        assert row["range_m"] == pytest.approx(C * (rate * (t_a - t_p) - TURNAROUND) / 2, abs=1e-7)
        if ppm == 0:
            assert row["range_m"] == pytest.approx(row["range_true_m"], abs=1e-7)
    tw = result.channel["two_way"]
    assert tw["turnaround_s"] == TURNAROUND and len(tw["t_poll_s"]) == 3


def test_replies_are_the_input_frames_retimed():
    """Still vehicle (profile mode, v = 0): the output is the input burst moved to t_poll + 2R/c + turnaround."""
    r0, offset = 150.0, -0.3
    data = {
        "mode": "profile",
        "doppler": {"initial_range_m": r0, "components": [{"kind": "constant", "v_mps": 0.0}]},
        "environment": {"sound_speed_mps": C},
        "clock": {"offset_s": offset},
        "two_way": {"turnaround_s": TURNAROUND, "poll_times_s": [0.05, 0.83, 1.61]},
    }
    t = np.arange(round(1.3 * FS)) / FS
    result = run(data, burst(t))
    y = result.output
    t_rx = np.arange(y.size) / FS
    polls = np.array([0.05, 0.83, 1.61])
    expected = np.zeros_like(t_rx)
    for k, t_poll in enumerate(polls):
        # reply k heard (vehicle clock) from t_poll + 2 r0/c + turnaround: the input frame k, shifted
        shift = t_poll + 2 * r0 / C + TURNAROUND - T_IN[k]
        u = t_rx - shift - T_IN[k] - 0.15
        expected += np.exp(-0.5 * (u / 0.01) ** 2) * np.cos(2 * np.pi * 20000.0 * u)
    err_db = 20 * np.log10(np.max(np.abs(y - expected)) / np.max(np.abs(expected)))
    assert err_db < -60
    for k, row in enumerate(result.truth):
        assert row["t_arrival_s"] == pytest.approx(polls[k] + 2 * r0 / C + TURNAROUND, abs=1e-12)
        assert row["range_m"] == pytest.approx(r0, abs=1e-9)


@pytest.mark.parametrize(
    "two_way,name,text",
    [
        ({"poll_period_s": 1.0}, "two_way.turnaround_s", "required"),
        ({"turnaround_s": -0.1, "poll_period_s": 1.0}, "two_way.turnaround_s", ">= 0"),
        ({"turnaround_s": 0.2}, "two_way.poll_period_s", "exactly one"),
        ({"turnaround_s": 0.2, "poll_period_s": 1.0, "poll_times_s": [0.0]}, "two_way.poll_period_s", "exactly one"),
        ({"turnaround_s": 0.2, "poll_times_s": [0.0, 0.0]}, "two_way.poll_times_s", "increasing"),
        ({"turnaround_s": 0.2, "poll_period_s": 0.0}, "two_way.poll_period_s", "> 0"),
        ({"turnaround_s": 0.2, "poll_period_s": 1.0, "polls": 3}, "two_way.polls", "unknown"),
    ],
)
def test_bad_two_way_tables_name_the_key(two_way, name, text):
    data = geometry()
    data["two_way"] = two_way
    with pytest.raises(ConfigError, match=f"^{name}.*{text}"):
        parse_scenario(data)


def test_polls_that_do_not_fit_the_frames():
    with pytest.raises(ConfigError, match="two_way.poll_times_s.*2 polls.*3 frames"):
        run(geometry(poll_times_s=[0.0, 1.0]))
    with pytest.raises(ConfigError, match="two_way.poll_period_s.*overlap"):
        run(geometry(poll_period_s=0.2))  # replies 0.2 s apart, frames last 0.3 s
    data = geometry(first_poll_s=0.1, poll_period_s=1.0)
    data["clock"] = {"offset_s": 1.0}  # vehicle clock ahead: its poll at 0.1 s is true time −0.9 s
    with pytest.raises(ConfigError, match="two_way.first_poll_s.*before|two_way.first_poll_s.*< 0"):
        run(data)


def test_two_way_does_not_apply_to_replay():
    with pytest.raises(ConfigError, match="^two_way"):
        parse_scenario({"mode": "replay", "replay": {"file": "x.mat"}, "two_way": {"turnaround_s": 0.1,
                                                                                   "poll_period_s": 1.0}})
