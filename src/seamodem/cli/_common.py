"""Options shared by several subcommands."""

from __future__ import annotations

import argparse
import contextlib
import json
import shlex
import sys
import warnings

from pathlib import Path

from ..config import FrameConfig, get_preset, load_config
from ..errors import SeamodemError
from ..io.files import check_writable

__all__ = ["sound_speed", "sound_speed_words", "add_profile_option", "sound_speed_profile", "add_config_options", "config_from_args", "command_line", "emit_schedule",
           "output_path", "reported_warnings"]


def sound_speed(args, sidecar: dict | None) -> tuple[float, str]:
    """c for every receiver mode: --sound-speed, else the recording's sidecar, else 1500 m/s.

    Outside 1400–1600 m/s it is refused unless ``--force-sound-speed``
    (:func:`~seamodem.receive.settings.resolve_sound_speed`). Returns (c [m/s], where it came from:
    "option", "sidecar" or "default"), the origin for the run's summary (:func:`sound_speed_words`).
    """
    from ..errors import ConfigError, SeamodemError
    from ..receive.settings import resolve_sound_speed

    try:
        return resolve_sound_speed(args.sound_speed, sidecar, force=args.force_sound_speed)
    except ConfigError as exc:
        raise SeamodemError(f"sound-speed: {exc.message}") from None


def sound_speed_words(value: float, origin: str) -> str:
    """``c = 1500 m/s ...`` for a run's summary, saying so when it is the default nobody gave."""
    if origin == "default":
        return f"c = {value:g} m/s: the default, neither --sound-speed nor the recording's sidecar gave one"
    return f"c = {value:g} m/s from the {origin}"


def add_profile_option(parser, *, what: str) -> None:
    """``--sound-speed-profile CSV`` (and ``--profile-latitude``), for the commands that turn travel time into range."""
    parser.add_argument("--sound-speed-profile", metavar="CSV",
                        help="sound-speed or CTD cast (depth_m,c_mps or depth_m|pressure_dbar,temperature_c,"
                             f"salinity_psu; TEOS-10): {what}")
    parser.add_argument("--profile-latitude", type=float, default=45.0, metavar="DEG",
                        help="latitude of the cast [deg], for pressure ↔ depth and TEOS-10 (default 45)")


def sound_speed_profile(args):
    """The profile ``--sound-speed-profile`` names, read and checked (one-line error naming the file), or None."""
    if not getattr(args, "sound_speed_profile", None):
        return None
    from ..water.cast import read_profile

    return read_profile(args.sound_speed_profile, latitude_deg=args.profile_latitude)


def add_config_options(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("frame configuration")
    group.add_argument("--preset", default="jmse2024", help="named preset (default: jmse2024; see `seamodem config --list`)")
    group.add_argument("--config", metavar="FILE", help="TOML or JSON file (or a sidecar) whose values override the preset")
    group.add_argument(
        "--set",
        metavar="KEY=VALUE",
        action="append",
        default=[],
        help="override one configuration value, e.g. --set rolloff=0.25 (repeatable)",
    )


def _parse_value(text: str):
    try:
        return json.loads(text)
    except json.JSONDecodeError:
        return text


def config_from_args(args: argparse.Namespace, *, config_file: str | None = None) -> FrameConfig:
    """Preset, then ``--config`` file (or ``config_file``, e.g. a recording's own sidecar), then ``--set`` overrides."""
    config = get_preset(args.preset)
    if args.config or config_file:
        config = load_config(args.config or config_file, base=config)
    overrides = {}
    for item in args.set:
        key, sep, value = item.partition("=")
        if not sep:
            raise ValueError(f"--set: expected KEY=VALUE, got {item!r}")
        overrides[key.strip()] = _parse_value(value.strip())
    if overrides:
        config = FrameConfig.from_dict(overrides, base=config)
    return config


def emit_schedule(args: argparse.Namespace):
    """The emissions ``--emit-start``/``--emit-period`` state, or None when neither is given.

    Parameters
    ----------
    args : argparse.Namespace
        With ``emit_start`` and ``emit_period`` [s].

    Returns
    -------
    Emissions or None

    Raises
    ------
    SeamodemError
        One of the two given without the other.
    """
    if args.emit_start is None and args.emit_period is None:
        return None
    if args.emit_start is None or args.emit_period is None:
        raise SeamodemError("emit-start: --emit-start and --emit-period go together")
    from ..receive.settings import Emissions

    return Emissions(start_s=args.emit_start, period_s=args.emit_period)


_ARGV: list[str] | None = None


def set_argv(argv: list[str]) -> None:
    """Remember the arguments of this invocation (called by :func:`seamodem.cli.main`)."""
    global _ARGV
    _ARGV = list(argv)


def command_line() -> str:
    """This invocation, as a shell command, for the sidecars."""
    return shlex.join(["seamodem", *(sys.argv[1:] if _ARGV is None else _ARGV)])


def output_path(path: str | Path, suffix: str) -> Path:
    """The ``-o`` path, checked for its suffix and a writable folder before any work."""
    out = Path(path)
    if out.suffix.lower() != suffix:
        raise SeamodemError(f"output: must be a {suffix} path, got {str(out)!r}")
    return check_writable(out)


#: warnings meant for developers, not for the user of a command
_DEVELOPER_WARNINGS = (DeprecationWarning, PendingDeprecationWarning, ImportWarning, ResourceWarning)


@contextlib.contextmanager
def reported_warnings(command: str):
    """Catch every warning raised inside; on leaving (also by an error), print each once, one line, on stderr.

    A warning's first line is printed as ``seamodem COMMAND: warning: ...``;
    the same message raised twice (a header read by two stages) is printed
    once. Developer warnings (deprecations, resources) go on to Python's own handler.

    Yields
    ------
    list of warnings.WarningMessage
        What has been caught so far.
    """
    caught: list = []
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            yield caught
    finally:
        lines = []
        for w in caught:
            if issubclass(w.category, _DEVELOPER_WARNINGS):
                warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
            else:
                lines.append(str(w.message).splitlines()[0] if str(w.message) else w.category.__name__)
        for line in dict.fromkeys(lines):
            print(f"seamodem {command}: warning: {line}", file=sys.stderr)
