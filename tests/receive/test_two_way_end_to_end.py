"""Two-way ranging end to end: seamodem tx → channel ([two_way]) → rx --turnaround, moving vehicle, clock offset."""

import json

import numpy as np
import pytest

from seamodem.cli import main
from seamodem.receive import read_measurements

TURNAROUND = 0.25

SCENARIO = """
mode = "geometry"
seed = 5
[environment]
sound_speed_mps = 1500.0
water_depth_m = 40.0
[beacon]
position_m = [0.0, 0.0, -10.0]
[vehicle]
start_m = [300.0, 80.0, -6.0]
velocity_mps = [-2.0, 0.5, 0.0]
[multipath]
max_bounces = 1
[noise]
kind = "white"
snr_db = 20.0
[clock]
offset_s = {offset}
[two_way]
turnaround_s = {turnaround}
first_poll_s = {first}
poll_period_s = 1.5
"""


@pytest.fixture(scope="module")
def replies(tmp_path_factory):
    d = tmp_path_factory.mktemp("two_way")
    wav = d / "tx.wav"
    assert main(["tx", "--preset", "jmse2024", "--count", "4", "--period", "0.5", "-q", "-o", str(wav)]) == 0
    return wav


# the vehicle's clock 3.7 s ahead of the beacon's, or 1.2 s behind: the polls are on the vehicle's clock
@pytest.mark.parametrize("offset,first", [(3.7, 4.0), (-1.2, 0.1)])
def test_two_way_range_measured_within_a_centimetre(replies, tmp_path, offset, first):
    scenario = tmp_path / "s.toml"
    scenario.write_text(SCENARIO.format(offset=offset, turnaround=TURNAROUND, first=first))
    rec = tmp_path / "rec.wav"
    assert main(["channel", str(replies), "--scenario", str(scenario), "-q", "-o", str(rec)]) == 0
    side = json.loads(rec.with_suffix(".json").read_text())
    meas = tmp_path / "m.csv"
    argv = ["rx", str(rec), "--config", str(rec.with_suffix(".json")), "--turnaround", str(TURNAROUND), "-o",
            str(meas), "-q"]
    assert main(argv) == 0
    recs, _ = read_measurements(meas)
    truth = side["truth"]
    assert [r.frame_index for r in recs] == [0, 1, 2, 3]
    assert [r.t_emit_s for r in recs] == [first + 1.5 * k for k in range(4)]  # the polls
    assert all(r.two_way for r in recs)
    measured = np.array([r.range_m for r in recs])
    # moving vehicle: the truth is the mean of the outbound range (at the poll) and the return range
    mean_range = np.array([(t["range_poll_m"] + t["range_reply_m"]) / 2 for t in truth])
    assert np.max(np.abs(measured - mean_range)) < 0.01  # CRLB at 20 dB: 0.3 mm
    # it is neither leg alone: the vehicle closes ≈ 1.2 m during a round trip
    assert np.all(np.abs(measured - np.array([t["range_reply_m"] for t in truth])) > 0.3)
    # the replies' payloads come through too, checked against the sidecar
    assert all(r.crc_ok and r.ber == 0.0 for r in recs)
    # without --turnaround, rx takes it from the sidecar's two-way exchange: the same ranges
    auto = tmp_path / "auto.csv"
    assert main(["rx", str(rec), "--config", str(rec.with_suffix(".json")), "-o", str(auto), "-q"]) == 0
    auto_recs = read_measurements(auto)[0]
    assert [r.range_m for r in auto_recs] == list(measured) and all(r.two_way for r in auto_recs)
