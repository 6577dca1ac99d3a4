"""End to end at the physical layer, with an analytic channel (not the project's channel code)."""

import numpy as np

from seamodem import build_frame, frame_symbol_times, get_preset, pb2bb, srrc_matrix
from seamodem.decode.equalizer import DfeSettings
from seamodem.receive.demodulate import decode_frame
from seamodem.receive.compensate import compensate_frame
from seamodem.transmit.frame import tone_envelope

C = 1500.0


def analytic_frame(frame, t_n, t_arrival, v):
    """s((1 + v/c)(t − t_arrival)): the frame as heard by a receiver closing at constant v."""
    cfg = frame.config
    tau = (1 + v / C) * (t_n - t_arrival)
    G = srrc_matrix(tau, frame_symbol_times(cfg), symbol_period_s=cfg.symbol_period_s, rolloff=cfg.rolloff,
                    span_symbols=cfg.srrc_span_symbols)
    a_d, a_t = np.sqrt(2 * (1 - cfg.tone_power_share)), np.sqrt(2 * cfg.tone_power_share)
    data = a_d * np.real((G @ frame.symbols) * np.exp(2j * np.pi * cfg.carrier_hz * tau))
    return data + a_t * tone_envelope(cfg, tau) * np.cos(2 * np.pi * cfg.tone_hz * tau)


def test_moving_multipath_frame_decodes_with_the_dfe_after_compensation():
    cfg = get_preset("jmse2024")
    fs = cfg.sample_rate_hz
    rng = np.random.default_rng(8)
    payload = b"positioning comes free with communication"
    fr = build_frame(cfg, payload)
    v, t_a = 3.0, 0.05
    t = np.arange(int(0.45 * fs)) / fs
    # direct path plus a surface echo 1.2 ms later, inverted and weaker, same Doppler
    r = analytic_frame(fr, t, t_a, v) - 0.5 * analytic_frame(fr, t, t_a + 1.2e-3, v)
    p_data = 1 - cfg.tone_power_share
    snr_db = 12.0
    n0 = p_data / (10 ** (snr_db / 10) * cfg.bandwidth_hz)
    r = r + rng.normal(0, np.sqrt(n0 * fs / 2), r.size)
    bb = pb2bb(r, fs, cfg.carrier_hz, passband_hz=cfg.bandwidth_hz / 2, stopband_hz=7800)
    comp = compensate_frame(bb, fs, 0.0, config=cfg, pilot=fr.pilot_symbols, t_start_s=t_a, sound_speed_mps=C,
                            v_mps=v)
    res = decode_frame(bb, fs, 0.0, comp, cfg, fr.pilot_symbols, settings=DfeSettings(n_ff=40, ff_centre=8, n_fb=24))
    assert res.passes == 1  # the DFE alone, no turbo pass needed at 12 dB
    assert res.decoded.crc_ok and res.decoded.payload == payload
