"""Receiver arrays (issue 17), session 5: flat and linear arrays, detection on all channels, the baseband path.

Independent answers: frames delayed to each element by an exact band-limited
plane-wave shift (tests/array/test_array.py's ``_plane_wave``), the single
detector's own statistics (:class:`~seamodem.receive.detect.PilotDetector`),
the Gamma(K, 1) tail of a sum of K unit exponentials, and the passband
correlation of the previous session against the new baseband one.
"""

import math
import warnings

import numpy as np
import pytest
import scipy.special

from seamodem.channel.array import array_preset, simulate_array
from seamodem.errors import ConfigError
from seamodem.receive.array import (
    ArrayDetector,
    array_correlation,
    array_geometry,
    baseband_correlation,
    blank_like_reference,
    estimate_doa,
    front_end_array,
    receive_array,
    unit_vector,
)
from seamodem.receive.detect import PilotDetector, z_threshold
from seamodem.receive.settings import Emissions, ReceiverSettings
from seamodem.transmit.pilot import pilot_symbols

from test_array import CFG, FS, C, TETRA, _beacon, _plane_wave, _scenario

PILOT = pilot_symbols(CFG.n_pilot, CFG.pilot_seed)


def _doa(x, positions_m, assume=None):
    corr = array_correlation(x, FS, config=CFG, pilot=PILOT, t_arrival_s=0.05, v_mps=0.0, sound_speed_mps=C)
    return estimate_doa(corr, positions_m, config=CFG, sound_speed_mps=C, assume=assume)


# --- geometry: volume, flat, linear ------------------------------------------------------------------

def test_geometry_kinds_and_refusals():
    assert array_geometry(TETRA.element_positions_m).kind == "volume"
    flat = array_geometry(array_preset("circle4").element_positions_m)
    assert (flat.kind, flat.assume) == ("planar", "below") and np.allclose(flat.axis, [0, 0, 1])
    assert "below" in flat.ambiguity
    line = array_geometry(array_preset("line4").element_positions_m, "starboard")
    assert (line.kind, line.assume) == ("linear", "starboard") and np.allclose(np.abs(line.axis), [1, 0, 0])
    with pytest.raises(ConfigError, match="vertically"):  # flat array in the x-z plane
        array_geometry(array_preset("circle4").element_positions_m[:, [0, 2, 1]])
    with pytest.raises(ConfigError, match="not .*horizontal"):
        array_geometry(array_preset("line3").element_positions_m[:, [2, 1, 0]])
    with pytest.raises(ConfigError, match="port"):
        array_geometry(array_preset("line3").element_positions_m, "below")
    with pytest.raises(ConfigError, match="no assumption"):
        array_geometry(TETRA.element_positions_m, "below")
    with pytest.raises(ConfigError, match="distinct"):
        array_geometry(np.zeros((4, 3)))


@pytest.mark.parametrize("el", [-0.5, -0.15])
def test_flat_array_takes_the_assumed_side(el):
    # a horizontal circle of 4: noiseless plane waves from below over the circle; 'below' recovers the truth,
    # 'above' returns its mirror image (elevation −el), the azimuth is measured either way
    p = array_preset("circle4").element_positions_m
    for az in np.radians(np.arange(-180, 180, 30)):
        x, _ = _plane_wave(p, az, el)
        d = _doa(x, p)
        assert abs(math.remainder(d.azimuth_rad - az, 2 * math.pi)) < np.radians(0.02), az
        assert abs(d.elevation_rad - el) < np.radians(0.05), az
        assert "below" in d.ambiguity
        m = _doa(x, p, assume="above")
        assert abs(m.elevation_rad + el) < np.radians(0.05) and abs(math.remainder(m.azimuth_rad - az, 2 * math.pi)) < 1e-3


def test_flat_array_sigma_in_noise_and_grows_towards_the_plane():
    # 12 dB per element; the elevation's σ (from ∂δ/∂e ∝ sin e for an in-plane array) is larger near the plane;
    # the errors are within 3σ in at least 58 of 60 angles
    p = array_preset("circle4").element_positions_m
    rng = np.random.default_rng(3)
    z, sig = [], {}
    for el in (-0.6, -0.2):
        for _ in range(15):
            az = rng.uniform(-np.pi, np.pi)
            x, _ = _plane_wave(p, az, el, snr_db=12.0, rng=rng)
            d = _doa(x, p)
            z += [abs(math.remainder(d.azimuth_rad - az, 2 * math.pi)) / d.sigma_azimuth_rad,
                  abs(d.elevation_rad - el) / d.sigma_elevation_rad]
            sig.setdefault(el, []).append(d.sigma_elevation_rad)
    assert np.sum(np.array(z) <= 3) >= 58
    assert np.median(sig[-0.2]) > 2 * np.median(sig[-0.6])


def test_linear_array_measures_the_cone_and_takes_the_assumed_side():
    # a fore-aft line of 4 (8 cm): plane waves at elevation 0 from port (az in (0, π)): 'port' gives az,
    # 'starboard' the mirror −az; elevation is not reported
    p = array_preset("line4").element_positions_m
    for az in np.radians([20, 60, 90, 135, 160]):
        x, _ = _plane_wave(p, az, 0.0)
        d = _doa(x, p)
        assert abs(d.azimuth_rad - az) < np.radians(0.05), az
        assert math.isnan(d.elevation_rad) and math.isnan(d.sigma_elevation_rad)
        s = _doa(x, p, assume="starboard")
        assert abs(s.azimuth_rad + az) < np.radians(0.05)
        assert "cone" in d.ambiguity


def test_linear_array_sigma_calibrated_in_noise():
    p = array_preset("line4").element_positions_m
    rng = np.random.default_rng(8)
    z = []
    for _ in range(30):
        az = rng.uniform(0.3, np.pi - 0.3)
        x, _ = _plane_wave(p, az, 0.0, snr_db=12.0, rng=rng)
        d = _doa(x, p)
        z.append(abs(d.azimuth_rad - az) / d.sigma_azimuth_rad)
    assert np.sum(np.array(z) <= 3) >= 29


# --- the baseband path -----------------------------------------------------------------------------

def test_baseband_correlation_matches_the_passband_one():
    # the same frame: c_k(δ) from the decimated basebands equals the passband analytic correlation
    # (the front end's filter is flat over the pilot's band: a few 1e-3 of |c|), and so do their noise levels
    rng = np.random.default_rng(5)
    x, delays = _plane_wave(TETRA.element_positions_m, 0.7, -0.3, snr_db=10.0, rng=rng)
    x = np.concatenate([0.2 * rng.standard_normal((int(0.1 * FS), 4)), x])  # noise before the frame
    t_a = 0.15
    pb = array_correlation(x, FS, config=CFG, pilot=PILOT, t_arrival_s=t_a, v_mps=0.0, sound_speed_mps=C)
    plan, bb, _, _ = front_end_array(x, FS, CFG, ReceiverSettings(blank_impulses=False))
    b = baseband_correlation(bb, plan.fs_data, plan.data.centre_hz, config=CFG, pilot=PILOT, t_arrival_s=t_a,
                             v_mps=0.0, sound_speed_mps=C)
    lags = np.linspace(-60e-6, 60e-6, 13)
    grid = np.broadcast_to(lags, (4, lags.size))
    ref = pb.at(grid)
    scale = FS / plan.fs_data  # the baseband sums one sample in 7: amplitudes and noise scale together
    assert np.max(np.abs(scale * b.at(grid) - ref)) < 0.02 * np.max(np.abs(ref))
    assert np.allclose(scale**2 * b.noise_var / pb.noise_var, 1.0, atol=0.25)
    d_pb = estimate_doa(pb, TETRA.element_positions_m, config=CFG, sound_speed_mps=C)
    d_bb = estimate_doa(b, TETRA.element_positions_m, config=CFG, sound_speed_mps=C)
    assert abs(d_pb.azimuth_rad - d_bb.azimuth_rad) < 0.2 * d_pb.sigma_azimuth_rad


# --- detection on all channels ---------------------------------------------------------------------

def test_array_detector_threshold_is_the_gamma_tail_and_one_channel_is_the_single_detector():
    rng = np.random.default_rng(2)
    fs_bb = FS / 7
    kw = dict(v_max_mps=5.0, sound_speed_mps=C, false_alarms_per_hour=0.01)
    one, single = ArrayDetector(CFG, fs_bb, 1, **kw), PilotDetector(CFG, fs_bb, **kw)
    assert one.eta == pytest.approx(z_threshold(0.01, len(single.doppler_hz), fs_bb), rel=1e-9)
    four = ArrayDetector(CFG, fs_bb, 4, **kw)
    p_test = 0.01 / (len(single.doppler_hz) * fs_bb * 3600)
    # P(Gamma(4) > η) = e^{−η} Σ_{i<4} η^i / i!
    eta = four.eta
    assert math.exp(-eta) * sum(eta**i / math.factorial(i) for i in range(4)) == pytest.approx(p_test, rel=1e-6)
    # one channel: the same z and ρ as the single-hydrophone detector (noise + a pilot at a known lag)
    r = (rng.standard_normal(20000) + 1j * rng.standard_normal(20000)) / math.sqrt(2)
    r[5000:5000 + single.length] += 0.5 * single.template / math.sqrt(np.mean(np.abs(single.template) ** 2))
    z1, rho1, best1, _ = one.statistics(r[:, None])
    z0, rho0, best0, _ = single.statistics(r)
    assert np.allclose(z1, z0, rtol=1e-3)
    peaks = rho1 > 0  # the array detector's ρ is computed at the peaks of z above η
    assert peaks.any() and np.all(z0[peaks] >= single.eta) and np.allclose(rho1[peaks], rho0[peaks], rtol=1e-3)
    assert np.max(rho1) == pytest.approx(np.max(rho0[z0 >= single.eta]), rel=1e-3)


def test_statistic_in_noise_is_gamma_k():
    # pure complex Gaussian noise on 4 channels: per bin Z = Σ_k |c_k|²/σ_k² is Gamma(4, 1); the detector's z is the
    # max over its bins, so P(z > t) ≤ n_bins · P(Gamma(4) > t) and ≥ P(Gamma(4) > t): checked at t = 12
    rng = np.random.default_rng(6)
    det = ArrayDetector(CFG, FS / 7, 4, v_max_mps=5.0, sound_speed_mps=C)
    n = 60000
    r = (rng.standard_normal((n, 4)) + 1j * rng.standard_normal((n, 4))) * np.array([1.0, 2.0, 0.5, 3.0])
    z, _, _, _ = det.statistics(r)
    frac = np.mean(z > 12.0)
    tail = scipy.special.gammaincc(4, 12.0)
    assert tail < frac < len(det.base.doppler_hz) * tail


def test_four_hydrophones_detect_frames_one_misses():
    # −8 dB per element through the simulator (surface and bottom echoes): the combined detector finds
    # the frames the reference channel alone does not, at the same false-alarm rate
    x, t_emit = _beacon(count=4, period_s=1.0)
    arr = TETRA.__class__(**{**TETRA.__dict__, "heading_rad": 0.4})
    sim = simulate_array(x, FS, _scenario(snr_db=-8.0, seed=21), arr, t_emit_s=t_emit,
                         frame_duration_s=CFG.frame_duration_s, band_hz=CFG.data_band_hz)
    plan, bb, _, _ = front_end_array(sim.output, FS, CFG, ReceiverSettings())
    truth = [row["t_arrival_true_s"] for row in sim.truth]
    found = {}
    for k in (1, 4):
        det = ArrayDetector(CFG, plan.fs_data, k, v_max_mps=5.0, sound_speed_mps=C)
        d = det.find_all(bb[:, :k])
        found[k] = sum(any(abs(e.t_start_s - t) < 0.002 for e in d) for t in truth)
        assert len(d) == found[k]  # nothing but the frames
    assert found[4] == 4 and found[1] <= 1


def test_receive_array_warns_of_a_flat_array_assumption(tmp_path):
    import soundfile

    from seamodem.receive.array import receive_array_file
    from seamodem.receive.stream import ReceiverWarning

    x, t_emit = _beacon(count=1)
    arr = array_preset("circle4")
    arr = arr.__class__(**{**arr.__dict__, "heading_rad": 0.3})
    sim = simulate_array(x, FS, _scenario(snr_db=15.0, max_bounces=0), arr, t_emit_s=t_emit,
                         frame_duration_s=CFG.frame_duration_s, band_hz=CFG.data_band_hz)
    path = tmp_path / "flat.wav"
    soundfile.write(path, sim.output / np.max(np.abs(sim.output)), int(FS), subtype="FLOAT")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        recs = receive_array_file(path, CFG, arr.element_positions_m, emissions=Emissions(start_s=0.1, period_s=1.0),
                                  settings=ReceiverSettings(decode=False))
    assert any(issubclass(w.category, ReceiverWarning) and "flat array" in str(w.message) for w in caught)
    truth = sim.truth[0]["paths"][0]
    assert len(recs) == 1 and recs[0].n_channels == 4
    assert abs(math.remainder(recs[0].azimuth_body_rad - truth["azimuth_body_rad"], 2 * math.pi)) < 5 * recs[0].sigma_azimuth_body_rad
    assert recs[0].elevation_body_rad < 0


def test_a_click_blanked_on_the_reference_is_blanked_on_every_element():
    # a click reaching the 4 elements up to 5 samples apart (8 cm at 96 kHz): the impulse blanker runs on
    # channel 0 only; its stretch, widened by the spread, zeroes the click on every channel and little else
    from seamodem.receive.impulse import blank_impulses

    rng = np.random.default_rng(9)
    x = 0.1 * rng.standard_normal((20000, 4))
    for k, lag in enumerate((0, 5, -4, 3)):
        x[10000 + lag, k] += 50.0
    y0, _ = blank_impulses(x[:, 0])
    y = blank_like_reference(x, y0, 0, 6)
    assert np.all(np.abs(y[9990:10010]) < 1.0)
    assert np.count_nonzero(np.all(y == 0.0, axis=1)) < 40
