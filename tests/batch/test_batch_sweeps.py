"""The navigation Monte Carlo and the BER sweep on seamodem.batch: the same numbers on every backend."""

import functools
import json

import numpy as np
import pytest

from seamodem import get_preset
from seamodem.batch import map_tasks
from seamodem.studies.ber import ber_sweep
from seamodem.navigation.montecarlo import MissionConfig, run_monte_carlo

distributed = pytest.importorskip("distributed")

SHORT_PATH = {"lane_length_m": 40.0, "n_lanes": 2, "y0_m": 80.0}


def test_monte_carlo_is_identical_on_threads_serial_processes_and_dask(dask_client):
    config = MissionConfig(path=SHORT_PATH)
    kw = {"tcoms": (3, 6), "runs": 6, "seed": 5, "workers": 2}
    threads = run_monte_carlo(config, **kw)
    done = []
    results = [
        run_monte_carlo(config, backend="serial", **kw),
        run_monte_carlo(config, backend="processes", progress=done.append, **kw),
        run_monte_carlo(config, backend="dask", scheduler=dask_client, **kw),
    ]
    assert sum(done) == 6 * 2 * 2  # runs × T_com × filters
    for r in results:
        assert r.rows == threads.rows  # bit for bit: every run draws from (seed, run index)
        for key in threads.per_run_mean_error:
            assert np.array_equal(r.per_run_mean_error[key], threads.per_run_mean_error[key])
            assert np.array_equal(r.mean_track[key], threads.mean_track[key])


def test_ber_sweep_is_identical_serial_processes_and_dask(dask_client, tmp_path):
    cfg = get_preset("jmse2024")
    kw = {"frames": 2, "seed": 1, "base_dir": str(tmp_path)}
    serial = ber_sweep(cfg, None, [3.0, 8.0], **kw)
    procs = ber_sweep(cfg, None, [3.0, 8.0], mapper=functools.partial(map_tasks, backend="processes", workers=2), **kw)
    dask = ber_sweep(cfg, None, [3.0, 8.0], mapper=functools.partial(map_tasks, backend="dask", scheduler=dask_client),
                     **kw)
    as_text = [json.dumps([repr(p) for p in points]) for points in (serial, procs, dask)]
    assert as_text[0] == as_text[1] == as_text[2]
    assert serial[0].air_bit_errors != serial[1].air_bit_errors  # the points are distinct draws, not one repeated


def test_ber_and_nav_commands_give_the_same_tables_on_dask_and_locally(dask_client, tmp_path, monkeypatch):
    from seamodem.cli import main
    import seamodem.navigation.montecarlo as mc

    address = dask_client.scheduler.address
    ber = ["ber", "--snr", "3", "6", "--frames", "2", "--passes", "1", "-q"]
    assert main([*ber, "-o", str(tmp_path / "serial")]) == 0
    assert main([*ber, "--scheduler", address, "-o", str(tmp_path / "dask")]) == 0
    assert (tmp_path / "serial" / "ber.csv").read_text() == (tmp_path / "dask" / "ber.csv").read_text()

    monkeypatch.setattr(mc.MissionConfig.__dataclass_fields__["path"], "default_factory", lambda: dict(SHORT_PATH))
    nav = ["nav", "simulate", "--tcom", "3", "6", "--runs", "4", "--seed", "2", "-q"]
    assert main([*nav, "-o", str(tmp_path / "threads")]) == 0
    assert main([*nav, "--backend", "processes", "--workers", "2", "-o", str(tmp_path / "procs")]) == 0
    assert main([*nav, "--scheduler", address, "-o", str(tmp_path / "navdask")]) == 0
    table = (tmp_path / "threads" / "table.csv").read_text()
    assert table == (tmp_path / "procs" / "table.csv").read_text() == (tmp_path / "navdask" / "table.csv").read_text()
