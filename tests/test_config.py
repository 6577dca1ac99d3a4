import json

import pytest

from seamodem import PRESETS, ConfigError, FrameConfig, get_preset, load_config, save_config


@pytest.mark.parametrize("name", list(PRESETS))
@pytest.mark.parametrize("suffix", [".json", ".toml"])
def test_round_trip(tmp_path, name, suffix):
    cfg = get_preset(name)
    path = tmp_path / f"cfg{suffix}"
    save_config(cfg, path)
    assert load_config(path) == cfg


def test_preset_values_from_the_papers():
    j = get_preset("jmse2024")
    assert (j.sample_rate_hz, j.carrier_hz, j.symbol_rate_hz, j.tone_hz) == (96153, 28000, 6400, 20000)
    assert j.bandwidth_hz == pytest.approx(8960)
    assert j.frame_duration_s == pytest.approx(0.300)
    assert j.samples_per_symbol == pytest.approx(15.0239, abs=1e-4)
    o = get_preset("oceans2021")
    assert (o.carrier_hz, o.tone_hz, o.n_pilot, o.n_data, o.modulation) == (23000, 11000, 150, 2518, "bpsk")
    lo, hi = o.data_band_hz
    assert 17000 <= lo and hi <= 30000 and o.bandwidth_hz <= 13000
    assert o.sample_rate_hz >= 60000


def test_config_is_frozen_and_replace_validates():
    cfg = get_preset("jmse2024")
    with pytest.raises(AttributeError):
        cfg.rolloff = 0.3
    with pytest.raises(ConfigError, match="^rolloff"):
        cfg.replace(rolloff=1.2)


BAD = [
    ({"tone_hz": 28000.0}, "tone_hz", "inside the data band"),
    ({"tone_hz": 23300.0}, "tone_hz", "inside the data band"),  # within the 500 Hz guard of the band edge
    ({"tone_hz": 48076.5}, "tone_hz", "fs/2"),
    ({"tone_hz": 60000.0}, "tone_hz", "fs/2"),
    ({"carrier_hz": 45000.0}, "carrier_hz", "fs/2"),
    ({"carrier_hz": 50000.0}, "carrier_hz", "fs/2"),
    ({"rolloff": 1.5}, "rolloff", r"\[0, 1\]"),
    ({"rolloff": -0.1}, "rolloff", r"\[0, 1\]"),
    ({"sample_rate_hz": 0}, "sample_rate_hz", "> 0"),
    ({"symbol_rate_hz": -5}, "symbol_rate_hz", "> 0"),
    ({"modulation": "16qam"}, "modulation", "one of"),
    ({"srrc_span_symbols": 80}, "srrc_span_symbols", "guard"),
    ({"srrc_span_symbols": 7}, "srrc_span_symbols", "even"),
    ({"n_pilot": 3}, "n_pilot", ">= 8"),
    ({"n_data": 0}, "n_data", ">= 1"),
    ({"n_data": 20}, "n_data", "no payload"),
    ({"tone_power_share": 1.0}, "tone_power_share", r"\[0, 1\)"),
    ({"fec": "turbo"}, "fec", "one of"),
    ({"rolloff": "wide"}, "rolloff", "number"),
    ({"rolloff": float("nan")}, "rolloff", "finite"),
    ({"n_guard": 3.5}, "n_guard", "integer"),
    ({"n_guard": True}, "n_guard", "integer"),
]


@pytest.mark.parametrize("change,parameter,why", BAD)
def test_invalid_field_names_the_parameter(change, parameter, why):
    with pytest.raises(ConfigError, match=f"^{parameter}: .*{why}") as err:
        FrameConfig.from_dict(change, base=get_preset("jmse2024"))
    assert err.value.parameter == parameter
    assert "\n" not in str(err.value)


def test_unknown_and_missing_keys(tmp_path):
    with pytest.raises(ConfigError, match="^colour: unknown"):
        FrameConfig.from_dict({"colour": "blue"}, base=get_preset("jmse2024"))
    with pytest.raises(ConfigError, match="missing"):
        FrameConfig.from_dict({"sample_rate_hz": 48000})
    with pytest.raises(ConfigError, match="^preset: unknown preset 'nope'"):
        get_preset("nope")


def test_partial_file_overrides_a_base(tmp_path):
    path = tmp_path / "over.toml"
    path.write_text("rolloff = 0.25\nmodulation = \"qpsk\"\n")
    cfg = load_config(path, base=get_preset("jmse2024"))
    assert cfg.rolloff == 0.25 and cfg.modulation == "qpsk" and cfg.carrier_hz == 28000
    sidecar = tmp_path / "s.json"
    sidecar.write_text(json.dumps({"config": cfg.to_dict(), "format": "whatever"}))
    assert load_config(sidecar) == cfg
