"""Receiver arrays (issue 17): channel geometry, direction of arrival, combining, calibration, bearing fixes.

Independent answers: plane-wave delays −p·u/c of a known direction, frames
synthesised by direct SRRC summation at each element's delay (not through the
channel simulator), the noise variance of a correlation measured over many
noise draws, closed-form geometry for the single-frame fix.
"""

import math

import numpy as np
import pytest

from seamodem import get_preset
from seamodem.channel.array import (
    ReceiverArray,
    array_preset,
    direction_angles,
    load_array,
    rotation_body_to_world,
    simulate_array,
)
from seamodem.channel.scenario import parse_scenario
from seamodem.errors import ConfigError
from seamodem.navigation.bearing import (
    bearing_body,
    bearing_jacobian,
    elevation,
    elevation_jacobian,
    single_frame_fix,
)
from seamodem.receive.array import (
    array_correlation,
    calibrate_array,
    estimate_doa,
    receive_array,
    unit_vector,
)
from seamodem.receive.records import MeasurementRecord
from seamodem.receive.settings import Emissions, ReceiverSettings
from seamodem.transmit.beacon import BeaconSchedule, render_beacon
from seamodem.transmit.frame import build_frame, frame_waveform
from seamodem.transmit.pilot import pilot_symbols

CFG = get_preset("jmse2024")
FS = CFG.sample_rate_hz
C = 1500.0
TETRA = array_preset("tetra:0.08")


def _scenario(snr_db=12.0, max_bounces=1, seed=1):
    return parse_scenario({
        "mode": "geometry", "seed": seed,
        "environment": {"sound_speed_mps": C, "water_depth_m": 30.0},
        "beacon": {"position_m": [0.0, 0.0, -10.0]},
        "vehicle": {"start_m": [-200.0, 80.0, -5.0], "velocity_mps": [1.5, 0.3, 0.0]},
        "multipath": {"max_bounces": max_bounces, "surface_reflection": -1.0, "bottom_reflection": 0.5},
        "noise": {"kind": "white", "snr_db": snr_db},
    })


def _beacon(count=2, period_s=1.0):
    sig = render_beacon(CFG, BeaconSchedule(count=count, period_s=period_s, start_s=0.1))
    return np.concatenate(list(sig.blocks())), sig.schedule.emission_times()


def _plane_wave(positions_m, az, el, *, t_a=0.05, n=None, snr_db=None, rng=None):
    """The frame at each element's plane-wave delay −p·u/c by an exact band-limited shift (FFT phase ramp).

    Independent of the channel simulator and its interpolator: the SRRC frame is synthesised once and
    delayed by e^{−j2πfδ} on a zero-padded block.
    """
    s = _frame_samples()
    delays = t_a - positions_m @ unit_vector(az, el) / C
    n = n or int((t_a + CFG.frame_duration_s + 0.05) * FS)
    base = np.zeros(n)
    base[: s.size] = s
    f = np.fft.rfftfreq(n, 1 / FS)
    x = np.fft.irfft(np.fft.rfft(base)[:, None] * np.exp(-2j * np.pi * f[:, None] * delays[None, :]), n, axis=0)
    if snr_db is not None:
        band = CFG.data_band_hz[1] - CFG.data_band_hz[0]
        p_sig = 1.0 - CFG.tone_power_share  # in-band power of the data part (model units)
        sigma = math.sqrt(p_sig / 10 ** (snr_db / 10) / (2 * band / FS))
        x += sigma * rng.standard_normal(x.shape)
    return x, delays


_FRAME = []


def _frame_samples():
    if not _FRAME:
        _FRAME.append(frame_waveform(build_frame(CFG, b"array")))
    return _FRAME[0]


# --- channel ---------------------------------------------------------------------------------------

def test_rotation_conventions():
    # heading 90°: forward points north; pitch nose-up: forward gains +z; roll: port side rises
    assert np.allclose(rotation_body_to_world(np.pi / 2)[0] @ [1, 0, 0], [0, 1, 0])
    assert rotation_body_to_world(0.0, 0.1)[0][2, 0] == pytest.approx(math.sin(0.1))
    assert rotation_body_to_world(0.0, 0.0, 0.1)[0][2, 1] == pytest.approx(math.sin(0.1))
    for R in rotation_body_to_world([0.3, 1.0], [0.2, -0.1], [0.05, 0.4]):
        assert np.allclose(R @ R.T, np.eye(3))


def test_element_arrivals_are_plane_wave_delays_and_truth_directions_are_geometric():
    x, t_emit = _beacon(count=2)
    sim = simulate_array(x, FS, _scenario(snr_db=30.0), TETRA, t_emit_s=t_emit,
                         frame_duration_s=CFG.frame_duration_s, band_hz=CFG.data_band_hz)
    assert sim.output.shape[1] == 4
    vel = np.array([1.5, 0.3, 0.0])
    for row in sim.truth:
        assert row["heading_rad"] == pytest.approx(math.atan2(0.3, 1.5))
        direct = row["paths"][0]
        t = row["t_arrival_true_s"]
        r = np.array([-200.0, 80.0, -5.0]) + vel * t
        u_world = (np.array([0.0, 0.0, -10.0]) - r) / np.linalg.norm(np.array([0.0, 0.0, -10.0]) - r)
        az_w, el_w = direction_angles(u_world)
        assert direct["azimuth_world_rad"] == pytest.approx(float(az_w), abs=1e-9)
        assert direct["elevation_world_rad"] == pytest.approx(float(el_w), abs=1e-9)
        # level vehicle: body azimuth = world azimuth - heading
        assert direct["azimuth_body_rad"] == pytest.approx(float(az_w) - row["heading_rad"], abs=1e-9)
        u_body = unit_vector(direct["azimuth_body_rad"], direct["elevation_body_rad"])
        plane = -TETRA.element_positions_m @ u_body / C
        measured = np.array(row["element_t_arrival_s"]) - row["t_arrival_s"]
        # plane wave vs exact spherical delays of a moving receiver: curvature and v/c scale, < 0.05 µs
        assert np.max(np.abs(measured - plane)) < 5e-8
        # the surface echo arrives from above the direct path
        assert row["paths"][1]["elevation_body_rad"] > direct["elevation_body_rad"]


def test_array_options_are_checked():
    with pytest.raises(ConfigError, match="array.element_positions_m"):
        ReceiverArray(element_positions_m=[[0, 0, 0]])
    with pytest.raises(ConfigError, match="array.gain_db"):
        ReceiverArray(element_positions_m=TETRA.element_positions_m, gain_db=[0, 1])
    with pytest.raises(ConfigError, match="unknown array"):
        load_array("square")
    with pytest.raises(ConfigError, match="geometry scenario"):
        simulate_array(np.zeros(10), FS, parse_scenario({"mode": "profile", "doppler": {"initial_range_m": 100.0,
                       "components": [{"kind": "constant", "v_mps": 1.0}]}}), TETRA, band_hz=CFG.data_band_hz)


def test_array_file_round_trip(tmp_path):
    p = tmp_path / "a.toml"
    p.write_text("[array]\nelement_positions_m = [[0.04,0,0],[-0.04,0,0],[0,0.04,0.03],[0,-0.04,-0.03]]\n"
                 "heading_rad = 0.5\n")
    a = load_array(p)
    assert a.n_elements == 4 and a.heading_rad == 0.5
    b = ReceiverArray.from_dict(a.to_dict())
    assert np.array_equal(b.element_positions_m, a.element_positions_m)


# --- direction of arrival --------------------------------------------------------------------------

def _doa(x, t_a, positions_m=TETRA.element_positions_m):
    pilot = pilot_symbols(CFG.n_pilot, CFG.pilot_seed)
    corr = array_correlation(x, FS, config=CFG, pilot=pilot, t_arrival_s=t_a, v_mps=0.0, sound_speed_mps=C)
    return estimate_doa(corr, positions_m, config=CFG, sound_speed_mps=C), corr


def test_noise_variance_of_the_correlation_matches_noise_draws():
    # pure white noise: the predicted var(c_k) against 200 independent draws (±15 %: 200 samples give ±10 % at 1σ... 2σ)
    rng = np.random.default_rng(4)
    pilot = pilot_symbols(CFG.n_pilot, CFG.pilot_seed)
    vals, pred = [], []
    for _ in range(200):
        x = 0.3 * rng.standard_normal((12000, 2))
        corr = array_correlation(x, FS, config=CFG, pilot=pilot, t_arrival_s=0.05, v_mps=0.0, sound_speed_mps=C)
        vals.append(corr.at(np.zeros(2)))
        pred.append(corr.noise_var)
    emp = np.mean(np.abs(np.array(vals)) ** 2, axis=0)
    assert np.allclose(emp / np.mean(pred, axis=0), 1.0, atol=0.2)


def test_plane_wave_over_the_whole_circle_without_ambiguity():
    # noiseless direct summation: every 15° of azimuth at three elevations, error < 0.01°
    for el in (-0.6, 0.0, 0.4):
        for az in np.radians(np.arange(-180, 180, 15)):
            x, delays = _plane_wave(TETRA.element_positions_m, az, el)
            d, _ = _doa(x, 0.05)
            assert abs(math.remainder(d.azimuth_rad - az, 2 * math.pi)) < np.radians(0.01), (az, el)
            assert abs(d.elevation_rad - el) < np.radians(0.01)
            # relative lags: the common one also carries the frame's carrier phase
            assert np.allclose(d.lags_s - d.lags_s.mean(), delays - delays.mean(), atol=2e-9)


def test_doa_error_within_its_crlb_sigma_in_noise():
    # 12 dB per element: errors against σ over 40 draws (80 angles); |error| ≤ 3σ in all but at most 2 (99 %: 0.8 expected)
    rng = np.random.default_rng(7)
    z = []
    for _ in range(40):
        az, el = rng.uniform(-np.pi, np.pi), rng.uniform(-0.8, 0.8)
        x, _ = _plane_wave(TETRA.element_positions_m, az, el, snr_db=12.0, rng=rng)
        d, _ = _doa(x, 0.05)
        z.append(abs(math.remainder(d.azimuth_rad - az, 2 * math.pi)) / d.sigma_azimuth_rad)
        z.append(abs(d.elevation_rad - el) / d.sigma_elevation_rad)
        assert d.sigma_azimuth_rad < np.radians(1.0)
    z = np.array(z)
    assert np.sum(z > 3) <= 2
    # σ is not inflated either: the RMS of the normalised errors is near 1
    assert 0.7 < math.sqrt(np.mean(z**2)) < 1.3


def test_position_uncertainty_widens_sigma_to_cover_position_errors():
    # ±2 mm element errors (uniform per axis), 20 dB: with the nominal geometry and σ_p = 2/√3 mm in the
    # receiver, |error| ≤ 3σ over 30 arrays × directions (at most 1 outside: 99 %); without σ_p the fit's χ²
    # inflation catches part of it only (8 of 30 measured outside 3σ)
    rng = np.random.default_rng(12)
    inside, outside_without = 0, 0
    for _ in range(30):
        true = TETRA.element_positions_m + rng.uniform(-0.002, 0.002, (4, 3))
        az, el = rng.uniform(-np.pi, np.pi), rng.uniform(-0.5, 0.5)
        x, _ = _plane_wave(true, az, el, snr_db=20.0, rng=rng)
        pilot = pilot_symbols(CFG.n_pilot, CFG.pilot_seed)
        corr = array_correlation(x, FS, config=CFG, pilot=pilot, t_arrival_s=0.05, v_mps=0.0, sound_speed_mps=C)
        for sig_p in (0.002 / math.sqrt(3), 0.0):
            d = estimate_doa(corr, TETRA.element_positions_m, config=CFG, sound_speed_mps=C, position_sigma_m=sig_p)
            err = abs(math.remainder(d.azimuth_rad - az, 2 * math.pi))
            if sig_p:
                inside += err <= 3 * d.sigma_azimuth_rad
            else:
                outside_without += err > 3 * d.sigma_azimuth_rad
    assert inside >= 29
    assert outside_without >= 3


def test_vertical_flat_array_is_refused_for_direction_finding():
    # a flat array standing vertically (x-z plane): its mirror ambiguity is port/starboard, not the elevation's sign
    p = array_preset("circle4").element_positions_m[:, [0, 2, 1]]
    x, _ = _plane_wave(p, 0.3, 0.0)
    with pytest.raises(ConfigError, match="vertically"):
        _doa(x, 0.05, p)


def test_calibration_recovers_gain_and_phase_offsets():
    gains = np.array([0.0, 1.5, -2.0, 0.7])
    phases = np.array([0.0, 0.4, -1.1, 2.5])
    g = 10 ** (gains / 20) * np.exp(1j * phases)
    rng = np.random.default_rng(2)
    from scipy.signal import hilbert

    arrivals, dirs, xs = [], [], []
    for i, (az, el) in enumerate([(0.3, -0.2), (2.0, 0.1), (-1.5, 0.4)]):
        x, _ = _plane_wave(TETRA.element_positions_m, az, el, snr_db=20.0, rng=rng)
        xs.append((hilbert(x, axis=0) * g[None, :]).real)
        arrivals.append(0.05 + i * x.shape[0] / FS)
        dirs.append((az, el))
    gain_db, phase_rad = calibrate_array(np.vstack(xs), FS, CFG, TETRA.element_positions_m, arrivals_s=arrivals,
                                         directions_body_rad=dirs, sound_speed_mps=C)
    assert np.allclose(gain_db, gains, atol=0.1)  # 20 dB, 3 frames: noise ≈ 0.02 dB
    assert np.allclose(np.angle(np.exp(1j * (phase_rad - phases))), 0.0, atol=0.02)


def _calibration_frames(positions_m, directions, g, rng, snr_db=20.0):
    """Analytic plane-wave frames one after another from ``directions`` on elements at ``positions_m``, channel
    gains g applied to the analytic signals: (x, arrivals)."""
    from scipy.signal import hilbert

    xs, arrivals = [], []
    for i, (az, el) in enumerate(directions):
        x, _ = _plane_wave(positions_m, az, el, snr_db=snr_db, rng=rng)
        xs.append((hilbert(x, axis=0) * g[None, :]).real)
        arrivals.append(0.05 + i * x.shape[0] / FS)
    return np.vstack(xs), arrivals


def test_calibration_recovers_element_position_errors_and_removes_their_bias():
    # ±2 mm errors per axis and channel phase/gain offsets; a calibration run of 36 frames (12 azimuths at each of
    # three elevations), 20 dB: the errors (about their mean: a common translation is not measurable) come back
    # within 0.15 mm (σ of one frame's delay difference ≈ 0.06 mm), and on 8 other directions the receiver on the
    # calibrated geometry is within 3σ of the truth where the phase-only calibration is not (its σ
    # does not count the calibration's own error, a fraction of one frame's: hence the calibration's 36 frames)
    rng = np.random.default_rng(11)
    errors = rng.uniform(-0.002, 0.002, (4, 3))
    true_p = TETRA.element_positions_m + errors
    g = 10 ** (np.array([0.0, 1.0, -1.5, 0.5]) / 20) * np.exp(1j * np.array([0.0, 0.5, -0.8, 1.2]))
    cal_dirs = [(math.radians(a + 10 * j), el) for j, el in enumerate((-0.5, 0.0, 0.4)) for a in range(0, 360, 30)]
    x, arrivals = _calibration_frames(true_p, cal_dirs, g, rng)
    kw = dict(arrivals_s=arrivals, directions_body_rad=cal_dirs, sound_speed_mps=C)
    gain_db, phase_rad, err_hat = calibrate_array(x, FS, CFG, TETRA.element_positions_m, estimate_positions=True,
                                                  **kw)
    assert np.max(np.abs(err_hat - (errors - errors.mean(axis=0)))) < 1.5e-4
    assert np.allclose(gain_db, 20 * np.log10(np.abs(g)), atol=0.1)
    gain0, phase0 = calibrate_array(x, FS, CFG, TETRA.element_positions_m, **kw)  # phases only
    test_dirs = [(math.radians(a), (-0.3, 0.2)[i % 2]) for i, a in enumerate(range(15, 360, 45))]
    xt, t_test = _calibration_frames(true_p, test_dirs, g, rng)
    pilot = pilot_symbols(CFG.n_pilot, CFG.pilot_seed)
    z_cal, z_nominal = [], []
    for (az, el), t_a in zip(test_dirs, t_test):
        for gains, phases, p, z in ((gain_db, phase_rad, TETRA.element_positions_m + err_hat, z_cal),
                                    (gain0, phase0, TETRA.element_positions_m, z_nominal)):
            corr = array_correlation(xt, FS, config=CFG, pilot=pilot, t_arrival_s=t_a, v_mps=0.0, sound_speed_mps=C,
                                     complex_gains=10 ** (gains / 20) * np.exp(1j * phases))
            d = estimate_doa(corr, p, config=CFG, sound_speed_mps=C)
            z.append(max(abs(math.remainder(d.azimuth_rad - az, 2 * math.pi)) / d.sigma_azimuth_rad,
                         abs(d.elevation_rad - el) / d.sigma_elevation_rad))
    assert max(z_cal) <= 3.0
    # the phase-only calibration: beyond 3σ on several directions (3 of 8 here, up to 30σ)
    assert sum(v > 3.0 for v in z_nominal) >= 2 and max(z_nominal) > 10.0


def test_calibration_from_one_elevation_leaves_the_vertical_at_zero():
    # every frame at elevation −0.06 rad (a horizontal calibration run): the vertical components cannot be told
    # from a constant phase; the prior keeps them near zero, the horizontal ones are recovered
    rng = np.random.default_rng(12)
    errors = rng.uniform(-0.002, 0.002, (4, 3))
    dirs = [(math.radians(a), -0.06) for a in range(0, 360, 30)]
    x, arrivals = _calibration_frames(TETRA.element_positions_m + errors, dirs, np.ones(4), rng)
    _, _, err_hat = calibrate_array(x, FS, CFG, TETRA.element_positions_m, arrivals_s=arrivals,
                                    directions_body_rad=dirs, sound_speed_mps=C, estimate_positions=True)
    rel = errors - errors.mean(axis=0)
    assert np.max(np.abs(err_hat[:, :2] - rel[:, :2])) < 1.5e-4
    assert np.max(np.abs(err_hat[:, 2])) < 0.5 * np.max(np.abs(rel[:, 2]))
    with pytest.raises(ConfigError, match="position_prior_m"):
        calibrate_array(x, FS, CFG, TETRA.element_positions_m, arrivals_s=arrivals, directions_body_rad=dirs,
                        sound_speed_mps=C, estimate_positions=True, position_prior_m=0.0)


# --- through the simulator and the receiver --------------------------------------------------------

def test_receive_array_end_to_end_with_echoes():
    x, t_emit = _beacon(count=3)
    sim = simulate_array(x, FS, _scenario(snr_db=12.0), TETRA, t_emit_s=t_emit,
                         frame_duration_s=CFG.frame_duration_s, band_hz=CFG.data_band_hz)
    recs, doas = receive_array(sim.output, FS, CFG, TETRA.element_positions_m,
                               emissions=Emissions(start_s=0.1, period_s=1.0), settings=ReceiverSettings(decode=True))
    assert len(recs) == 3
    for r in recs:
        truth = sim.truth[r.frame_index]["paths"][0]
        assert r.n_channels == 4 and r.crc_ok
        err = abs(math.remainder(r.azimuth_body_rad - truth["azimuth_body_rad"], 2 * math.pi))
        assert err < np.radians(1.0)  # the goal at 12 dB
        assert err < 4 * r.sigma_azimuth_body_rad + np.radians(0.02)
        # the combined frame gains ≈ 10 log10(4) = 6 dB over one element's 12 dB
        assert r.snr_db > 12.0 + 4.0


def test_record_defaults_for_one_hydrophone():
    r = MeasurementRecord(0, 0.0, 0.1, 0.1, 150.0, 0.0, 10.0, 0.0, 0.0, 1.0, 1.0, 0.01, 0.01, 0.01, 50.0)
    assert r.n_channels == 1 and math.isnan(r.azimuth_body_rad) and math.isnan(r.sigma_elevation_body_rad)


# --- navigation ------------------------------------------------------------------------------------

def test_bearing_jacobians_match_numerical_derivatives():
    b = (50.0, 100.0, -20.0)
    x, y, z, psi = 10.0, -30.0, -5.0, 0.7
    h = 1e-6
    num = [(bearing_body(x + h, y, psi, b) - bearing_body(x - h, y, psi, b)) / (2 * h),
           (bearing_body(x, y + h, psi, b) - bearing_body(x, y - h, psi, b)) / (2 * h),
           (bearing_body(x, y, psi + h, b) - bearing_body(x, y, psi - h, b)) / (2 * h)]
    assert np.allclose(bearing_jacobian(x, y, b), num, rtol=1e-6)
    num = [(elevation(x + h, y, z, b) - elevation(x - h, y, z, b)) / (2 * h),
           (elevation(x, y + h, z, b) - elevation(x, y - h, z, b)) / (2 * h),
           (elevation(x, y, z + h, b) - elevation(x, y, z - h, b)) / (2 * h)]
    assert np.allclose(elevation_jacobian(x, y, z, b), num, rtol=1e-6)


def test_single_frame_fix_recovers_the_geometry_and_its_covariance_is_calibrated():
    b = np.array([50.0, 100.0, -20.0])
    rng = np.random.default_rng(3)
    truth = np.array([-80.0, 10.0, -5.0])
    psi = 2.2
    slant = float(np.linalg.norm(b - truth))
    az = float(bearing_body(truth[0], truth[1], psi, b))
    exact = single_frame_fix(slant, az, psi, b, z_m=truth[2], sigma_range_m=0.05, sigma_azimuth_rad=0.01,
                             sigma_heading_rad=0.02, sigma_z_m=0.1)
    assert np.allclose([exact.x_m, exact.y_m, exact.z_m], truth, atol=1e-9)
    el = float(elevation(*truth, b))
    from_el = single_frame_fix(slant, az, psi, b, elevation_rad=el, sigma_range_m=0.05, sigma_azimuth_rad=0.01,
                               sigma_heading_rad=0.02, sigma_elevation_rad=0.01)
    assert np.allclose([from_el.x_m, from_el.y_m, from_el.z_m], truth, atol=1e-9)
    # Monte Carlo, 2000 draws: sample covariance vs the fix's (first order + the second-order line-of-sight
    # term), ±12 %, at array-grade angles (0.2°, 0.3°) and at a 1° heading (where the second-order term
    # is 5 times the 5 cm range σ)
    for sa, sp in ((np.radians(0.2), np.radians(0.3)), (np.radians(0.2), np.radians(1.0))):
        lin = single_frame_fix(slant, az, psi, b, z_m=truth[2], sigma_range_m=0.05, sigma_azimuth_rad=sa,
                               sigma_heading_rad=sp, sigma_z_m=0.1)
        pts = []
        for _ in range(2000):
            f = single_frame_fix(slant + 0.05 * rng.standard_normal(), az + sa * rng.standard_normal(),
                                 psi + sp * rng.standard_normal(), b, z_m=truth[2] + 0.1 * rng.standard_normal(),
                                 sigma_range_m=0.05, sigma_azimuth_rad=sa, sigma_heading_rad=sp, sigma_z_m=0.1)
            pts.append([f.x_m, f.y_m])
        pts = np.array(pts)
        emp = np.cov(pts.T) + np.outer(pts.mean(0) - truth[:2], pts.mean(0) - truth[:2])  # MSE matrix (bias in)
        ev_emp, ev_fix = np.linalg.eigvalsh(emp), np.linalg.eigvalsh(lin.covariance[:2, :2])
        assert ev_emp[1] == pytest.approx(ev_fix[1], rel=0.12)
        assert 0.75 * ev_fix[0] <= ev_emp[0] <= 1.12 * ev_fix[0]  # the second-order term is 4/3 of bias² + var


def test_single_frame_fix_bad_input():
    with pytest.raises(ConfigError, match="range_m"):
        single_frame_fix(5.0, 0.0, 0.0, (0, 0, -20), z_m=-5.0, sigma_range_m=0.1, sigma_azimuth_rad=0.1,
                         sigma_heading_rad=0.1)
    with pytest.raises(ConfigError, match="z_m"):
        single_frame_fix(50.0, 0.0, 0.0, (0, 0, -20), sigma_range_m=0.1, sigma_azimuth_rad=0.1, sigma_heading_rad=0.1)


def test_channel_mismatch_through_the_simulator_is_removed_by_calibration():
    # the simulator's gain/phase mismatch biases the nominal receiver by degrees; calibrate_array on the same
    # recording's frames (directions from the truth) recovers the offsets, and the calibrated receiver is back
    # within its σ
    phases = np.array([0.0, 0.5, -0.8, 1.2])
    gains = np.array([0.0, 1.0, -1.5, 0.5])
    arr = ReceiverArray(element_positions_m=TETRA.element_positions_m, gain_db=gains, phase_rad=phases)
    x, t_emit = _beacon(count=3)
    sim = simulate_array(x, FS, _scenario(snr_db=20.0), arr, t_emit_s=t_emit,
                         frame_duration_s=CFG.frame_duration_s, band_hz=CFG.data_band_hz)
    em = Emissions(start_s=0.1, period_s=1.0)
    nominal, _ = receive_array(sim.output, FS, CFG, TETRA.element_positions_m, emissions=em, combine=False)
    err = [abs(math.remainder(r.azimuth_body_rad - sim.truth[r.frame_index]["paths"][0]["azimuth_body_rad"],
                              2 * math.pi)) for r in nominal]
    assert min(err) > np.radians(1.0)
    dirs = [(sim.truth[r.frame_index]["paths"][0]["azimuth_body_rad"],
             sim.truth[r.frame_index]["paths"][0]["elevation_body_rad"]) for r in nominal]
    gain_db, phase_rad = calibrate_array(sim.output, FS, CFG, TETRA.element_positions_m,
                                         arrivals_s=[r.t_arrival_s for r in nominal], directions_body_rad=dirs,
                                         v_mps=[r.v_r_bank_mps for r in nominal], sound_speed_mps=C)
    assert np.allclose(gain_db, gains, atol=0.15)
    assert np.allclose(np.angle(np.exp(1j * (phase_rad - phases))), 0.0, atol=0.03)
    g = 10 ** (gain_db / 20) * np.exp(1j * phase_rad)
    calibrated, _ = receive_array(sim.output, FS, CFG, TETRA.element_positions_m, emissions=em, complex_gains=g,
                                  combine=False)
    for r in calibrated:
        truth = sim.truth[r.frame_index]["paths"][0]
        e = abs(math.remainder(r.azimuth_body_rad - truth["azimuth_body_rad"], 2 * math.pi))
        assert e < 3 * r.sigma_azimuth_body_rad + np.radians(0.02)


def test_a_frame_cut_by_the_recording_keeps_its_record_without_direction():
    # the recording starts 1 ms before the first frame's arrival: the detector still finds it on channel 0,
    # its pilot window lies outside the recording, so it has no direction but is not dropped
    x, t_emit = _beacon(count=2)
    sim = simulate_array(x, FS, _scenario(snr_db=20.0, max_bounces=0), TETRA, t_emit_s=t_emit,
                         frame_duration_s=CFG.frame_duration_s, band_hz=CFG.data_band_hz)
    cut = int((sim.truth[0]["t_arrival_s"] - 0.001) * FS)
    em = Emissions(start_s=0.1 - cut / FS, period_s=1.0)
    recs, doas = receive_array(sim.output[cut:], FS, CFG, TETRA.element_positions_m, emissions=em)
    assert [r.frame_index for r in recs] == [0, 1]
    assert recs[0].n_channels == 1 and doas[0] is None and math.isnan(recs[0].azimuth_body_rad)
    assert recs[1].n_channels == 4 and math.isfinite(recs[1].azimuth_body_rad)
    for r, d in zip(recs, doas):
        assert (d is None) == (r.n_channels == 1) and (d is None) == math.isnan(r.azimuth_body_rad)
