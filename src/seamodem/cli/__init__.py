"""The ``seamodem`` command line: one program, one subcommand per use.

Every subcommand module defines ``add_parser(subparsers)`` and ``run(args) -> int``.
Errors the user can fix are printed as one line, ``seamodem CMD: error: …``,
with exit code 2; no traceback (set SEAMODEM_DEBUG=1 to see one).
"""

from __future__ import annotations

import importlib
import os
import sys

from .._version import __version__
from ..errors import SeamodemError

__all__ = ["main", "COMMANDS"]

#: Subcommand modules, in the order ``seamodem --help`` lists them.
COMMANDS = ("demo", "tx", "channel", "rx", "ber", "plot", "config", "nav")


def _parser():
    from ._parsing import SeamodemParser

    parser = SeamodemParser(
        prog="seamodem",
        description="Underwater acoustic modem toolkit: communicate and navigate with the same signal.",
    )
    parser.add_argument("--version", action="version", version=f"seamodem {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name in COMMANDS:
        try:
            module = importlib.import_module(f".{name}", __name__)
        except ModuleNotFoundError as exc:
            if exc.name == f"{__name__}.{name}":
                continue  # subcommand not built yet
            raise
        module.add_parser(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``seamodem``; returns the exit code."""
    from ._common import set_argv

    argv = sys.argv[1:] if argv is None else [str(a) for a in argv]
    set_argv(argv)
    parser = _parser()
    args = parser.parse_args(argv)
    prefix = f"seamodem {args.command}: error:"
    try:
        return int(args.run(args) or 0)
    except (SeamodemError, ValueError, OSError) as exc:
        if os.environ.get("SEAMODEM_DEBUG"):
            raise
        message = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        print(f"{prefix} {message}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"seamodem {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
