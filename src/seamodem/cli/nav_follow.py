"""``seamodem nav track --follow``: positions in real time from records as they arrive, out as CSV/JSONL and NMEA.

nav.py only branches here. The records come from :class:`~seamodem.navigation.follow.RecordFollower` (a file
that grows, a FIFO, stdin), each becomes a position (:class:`~seamodem.navigation.follow.FollowTracker`),
written and flushed at once (``-o -``: stdout) and, with ``--nmea udp://HOST:PORT``, sent as GGA and RMC
sentences (:mod:`seamodem.navigation.nmea`). Exit codes: 0 the input ended (the pipe closed, or the file's
sidecar says the run is complete); 3 nothing arrived for ``--stall-timeout``; 4 the output's reader went away;
130 Ctrl-C or SIGTERM.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import signal
import socket
import sys
import threading
import time
from datetime import datetime, timezone
from pathlib import Path

from ..errors import SeamodemError

__all__ = ["add_follow_options", "follow", "run_follow", "parse_udp", "warm_up"]

EXIT_CODES = {"end of stream": 0, "complete": 0, "stalled": 3, "output closed": 4, "interrupted": 130}


def add_follow_options(t: argparse.ArgumentParser) -> None:
    """``--follow`` and what goes with it (docs/live.md)."""
    g = t.add_argument_group(
        "real time (docs/live.md)",
        "--follow: read MEAS (a file that grows, a FIFO, or '-' for stdin) as records arrive and write each "
        "position as it is computed (-o OUT.csv, OUT.jsonl or '-'): the filter's position at each record and, "
        "with --fixed-lag S, the smoothed one S seconds behind (column estimate: filter or smoothed).",
    )
    g.add_argument("--follow", action="store_true", help="follow the records as they arrive (real time)")
    g.add_argument("--nmea", metavar="udp://HOST:PORT",
                   help="send each position as NMEA 0183 GGA and RMC over UDP (needs --geodetic)")
    g.add_argument("--utc-start", metavar="ISO8601",
                   help="UTC of the stream's t = 0, for the NMEA time (default: when --follow starts)")
    g.add_argument("--stall-timeout", type=float, metavar="S",
                   help="with --follow: stop (exit 3) when no record arrives for S seconds")


def parse_udp(text: str) -> tuple[str, int]:
    """(host, port) of ``udp://HOST:PORT``; one-line error otherwise.

    Parameters
    ----------
    text : str

    Returns
    -------
    (str, int)
    """
    rest = text[len("udp://"):] if text.startswith("udp://") else None
    host, _, port = (rest or "").rpartition(":")
    if not rest or not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise SeamodemError(f"nmea: must be udp://HOST:PORT (port 1-65535), got {text!r}")
    return host.strip("[]"), int(port)


def _utc_start(text: str | None) -> float:
    if text is None:
        return time.time()
    try:
        t = datetime.fromisoformat(text.replace("Z", "+00:00"))
    except ValueError:
        raise SeamodemError(f"utc-start: must be an ISO 8601 time (2026-11-26T17:00:00Z), got {text!r}") from None
    return (t if t.tzinfo else t.replace(tzinfo=timezone.utc)).timestamp()


def _check(args: argparse.Namespace) -> None:
    for name in ("smooth", "truth", "fixes", "depth_log"):
        if getattr(args, name):
            raise SeamodemError(f"{name.replace('_', '-')}: not with --follow (real-time positions are the "
                                "filter's and --fixed-lag's; run nav track on the complete file afterwards)")
    if args.fixed_lag is not None and not (math.isfinite(args.fixed_lag) and args.fixed_lag > 0):
        raise SeamodemError(f"fixed-lag: must be > 0 [s], got {args.fixed_lag!r}")
    if args.filter not in ("inertial", "inertial-range"):
        raise SeamodemError(f"filter: --follow runs the inertial filters, not {args.filter!r}")
    if args.nmea and not args.geodetic:
        raise SeamodemError("nmea: NMEA positions are latitude, longitude: give --geodetic and --beacon LAT,LON")
    if args.stall_timeout is not None and not (math.isfinite(args.stall_timeout) and args.stall_timeout > 0):
        raise SeamodemError(f"stall-timeout: must be > 0 [s], got {args.stall_timeout!r}")
    if args.output != "-" and Path(args.output).suffix.lower() not in (".csv", ".jsonl"):
        raise SeamodemError(f"output: with --follow must end in .csv or .jsonl, or be '-', got {args.output!r}")


class _Output:
    """Positions, one row each, flushed as written; the configuration first (sidecar beside, or first line)."""

    def __init__(self, target: str, meta: dict, columns: list[str], stdout):
        import csv

        self.kind = "jsonl" if target == "-" or target.lower().endswith(".jsonl") else "csv"
        self.columns = columns
        if target == "-":
            self.f = stdout
            self.f.write(json.dumps(meta) + "\n")
        else:
            from ..io.files import check_writable

            path = check_writable(target)
            self.sidecar = path.with_suffix(".json")
            self.sidecar.write_text(json.dumps(meta, indent=1) + "\n", encoding="utf-8")
            self.f = path.open("w", newline="", encoding="utf-8")
        self.target, self.meta = target, meta
        self.csv = csv.writer(self.f) if self.kind == "csv" else None
        if self.csv is not None:
            self.csv.writerow(columns)
        self.f.flush()

    def write(self, row: dict) -> None:
        if self.csv is not None:
            self.csv.writerow(["" if isinstance(row[c], float) and not math.isfinite(row[c]) else row[c]
                               for c in self.columns])
        else:
            self.f.write(json.dumps({c: (None if isinstance(row[c], float) and not math.isfinite(row[c]) else row[c])
                                     for c in self.columns}) + "\n")
        self.f.flush()

    def close(self, **end) -> None:
        if self.target != "-":
            self.f.close()
            self.sidecar.write_text(json.dumps(self.meta | end, indent=1) + "\n", encoding="utf-8")


def follow(args: argparse.Namespace, config, command: str) -> int:
    """``nav track --follow``: the options as the filter's, then :func:`run_follow`.

    Parameters
    ----------
    args : argparse.Namespace
        ``nav track``'s options.
    config : InertialConfig
        The filter's noise and states, from the options.
    command : str
        The command line, for the sidecar.

    Returns
    -------
    int
        The exit code.
    """
    from ..navigation.geometry import check_lat_lon
    from ..navigation.logs import parse_pair, parse_position

    _check(args)
    if args.geodetic:
        origin = parse_position(args.beacon, geodetic=False, parameter="beacon")
        check_lat_lon(*origin, "beacon")
        beacon_xy = (0.0, 0.0)
        start_xy = parse_position(args.start, geodetic=True, origin=origin, parameter="start")
    else:
        origin, beacon_xy, start_xy = None, parse_pair(args.beacon, "beacon"), parse_pair(args.start, "start")
    if not Path(args.imu).is_file():
        raise SeamodemError(f"imu: file not found: {args.imu}")
    options = dict(beacon_xy=beacon_xy, start_xy=start_xy, start_speed_mps=args.start_speed, filter=args.filter,
                   depths=args.depth, beacon_depth_m=args.beacon_depth, sound_speed_profile=args.profile,
                   config=config, range_floor_m=args.range_floor, v_r_floor_mps=args.vr_floor,
                   sigma_range_m=args.sigma_range, sigma_v_r_mps=args.sigma_vr, start_sigma_m=args.start_sigma,
                   use_bearing=not args.no_bearing, bearing_floor_rad=math.radians(args.bearing_floor))
    return run_follow(args, options, origin, command)


def warm_up(track_options: dict, lag_s: float | None = None) -> None:
    """Follow a synthetic record once before the first real one (the kernels' first calls).

    The first position of a run otherwise pays for them (about 0.4 s here, benchmarks/bench_live.py);
    the records that arrive meanwhile wait in the pipe.

    Parameters
    ----------
    track_options : dict
        :class:`~seamodem.navigation.follow.FollowTracker` options.
    lag_s : float, optional
        The fixed-lag smoother's lag [s] (its kernels too).
    """
    import numpy as np

    from ..navigation.follow import FollowTracker

    (bx, by), (sx, sy) = track_options["beacon_xy"], track_options["start_xy"]
    d = math.hypot(sx - bx, sy - by) + 100.0  # beyond any depth difference
    t = np.arange(0.0, 2.01, 0.25)
    zeros = np.zeros(t.size)
    imu = {"t_s": t, "heading_rad": zeros, "omega_rad_s": zeros, "accel_mps2": zeros}
    try:
        tracker = FollowTracker(imu, track_options, lag_s=None if lag_s is None else min(lag_s, 1.0))
        for k, t_a in enumerate((0.2, 1.1)):
            tracker.add({"frame_index": float(k), "t_emit_s": t_a - d / 1500.0, "t_arrival_s": t_a,
                         "tof_s": d / 1500.0, "range_m": d, "v_r_mps": 0.0, "snr_db": 20.0})
        tracker.finish()
    except (SeamodemError, ValueError):  # the real records say what is wrong, if anything
        pass


def run_follow(args: argparse.Namespace, track_options: dict, origin, command: str) -> int:
    """Follow MEAS, write each position, send NMEA; the exit code of why it ended.

    Parameters
    ----------
    args : argparse.Namespace
        ``nav track``'s options.
    track_options : dict
        :func:`~seamodem.navigation.track.run_track` keywords (beacon, start, filter, noise...).
    origin : (float, float) or None
        (lat, lon) of the beacon with ``--geodetic`` [deg].
    command : str
        The command line, for the sidecar.

    Returns
    -------
    int
    """
    from ..navigation.follow import FollowTracker, RecordFollower
    from ..navigation.geometry import local_to_geodetic

    t0 = _utc_start(args.utc_start)
    udp = parse_udp(args.nmea) if args.nmea else None
    stop = threading.Event()
    follower = RecordFollower(args.measurements, stop=stop, idle_timeout_s=args.stall_timeout)
    lag = args.fixed_lag
    tracker = FollowTracker(args.imu, track_options, lag_s=lag)
    columns = ["estimate", "lag_s", "t_s", "x_m", "y_m", "heading_rad", "speed_mps", "var_x_m2", "cov_xy_m2",
               "var_y_m2"]
    columns += ["lat_deg", "lon_deg"] if origin is not None else []
    columns += ["frame_index", "t_arrival_s", "status", "nis"]
    meta = {"format": "seamodem.track-follow/2", "command": command, "measurements": args.measurements,
            "imu": args.imu, "beacon": args.beacon, "start": args.start, "geodetic": bool(args.geodetic),
            "filter": args.filter, "fixed_lag_s": lag,
            "estimates": "filter: the filter's position at each record, written as the record arrives"
                         + ("" if lag is None else f"; smoothed: the fixed-lag smoother's position at a record, "
                            f"written once the filter is {lag:g} s past it (lag_s: the lag used, shorter at the "
                            "end of the input)"),
            "nmea": args.nmea, "utc_start": datetime.fromtimestamp(t0, timezone.utc).isoformat(),
            "track_options": {k: v for k, v in track_options.items() if k not in ("config", "sound_speed_profile")},
            "inertial_config": _jsonable(track_options.get("config")), "columns": columns, "complete": False}
    stdout = sys.stdout
    sys.stdout = sys.stderr
    old = {}

    def on_signal(signum, frame):
        stop.set()

    for sig in (signal.SIGINT, signal.SIGTERM):
        old[sig] = signal.signal(sig, on_signal)
    sock = socket.socket(socket.AF_INET6 if ":" in udp[0] else socket.AF_INET, socket.SOCK_DGRAM) if udp else None
    out = _Output(args.output, meta, columns, stdout)
    warm_up(track_options, lag)
    counts = {"filter": 0, "smoothed": 0}

    def emit(pos: dict) -> bool:
        """Write a position (and send it, the filter's); False when the output's reader has gone."""
        if origin is not None:
            lat, lon = local_to_geodetic(pos["x_m"], pos["y_m"], *origin)
            pos["lat_deg"], pos["lon_deg"] = float(lat), float(lon)
        if sock is not None and pos["estimate"] == "filter":
            _send_nmea(sock, udp, pos, t0, args.depth[0] if args.depth else 0.0, tracker.warnings)
        try:
            out.write(pos)
        except BrokenPipeError:
            os.dup2(os.open(os.devnull, os.O_WRONLY), stdout.fileno())
            return False
        counts[pos["estimate"]] += 1
        return True

    reason = None
    try:
        for row in follower:
            if not all(emit(pos) for pos in tracker.add(row)):
                reason = "output closed"
                break
        if reason is None and not all(emit(pos) for pos in tracker.finish()):
            reason = "output closed"
    finally:
        follower.close()
        for sig, handler in old.items():
            signal.signal(sig, handler)
        sys.stdout = stdout
        if sock is not None:
            sock.close()
    reason = reason or follower.end_reason or "end of stream"
    n = counts["filter"]
    out.close(complete=True, ended=reason, positions=n, smoothed_positions=counts["smoothed"],
              warnings=tracker.warnings)
    for line in tracker.warnings:
        print(f"seamodem nav track: warning: {line}", file=sys.stderr)
    smoothed = f" and {counts['smoothed']} smoothed ({lag:g} s lag)" if lag is not None else ""
    print(f"seamodem nav track: {reason}: {n} position{'s' if n != 1 else ''}{smoothed} written to "
          f"{'stdout' if args.output == '-' else args.output}" + (f", the filter's sent to {args.nmea}" if udp else ""),
          file=sys.stderr)
    return EXIT_CODES.get(reason, 1)


def _send_nmea(sock, udp, pos: dict, t0: float, depth: float, notes: list) -> None:
    """GGA and RMC of a position, one datagram each; a destination that refuses is noted once."""
    from ..navigation.nmea import gga, rmc

    t_utc = t0 + pos["t_s"]
    sigma = math.sqrt(max(pos["var_x_m2"] + pos["var_y_m2"], 0.0))
    for text in (gga(time_s=t_utc, lat_deg=pos["lat_deg"], lon_deg=pos["lon_deg"], sigma_m=sigma, altitude_m=-depth),
                 rmc(time_s=t_utc, lat_deg=pos["lat_deg"], lon_deg=pos["lon_deg"], speed_mps=pos["speed_mps"],
                     course_deg=90.0 - math.degrees(pos["heading_rad"]))):
        try:
            sock.sendto(text.encode("ascii"), udp)
        except OSError as exc:  # nobody listening yet (ICMP refused): the next one may get through
            note = f"nmea: {udp[0]}:{udp[1]}: {exc.strerror}"
            if note not in notes:
                notes.append(note)


def _jsonable(config):
    from dataclasses import asdict

    return None if config is None else json.loads(json.dumps(asdict(config), default=str))
