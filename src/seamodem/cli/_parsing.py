"""The argument parser every ``seamodem`` command uses: one-line errors, negative numbers as values."""

from __future__ import annotations

import argparse
import re

__all__ = ["SeamodemParser"]

_NUMBER = r"-?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
#: what argparse must read as a value, not as an option: -3, -0.5, -1e-3 and pairs or lists such as -45,25
_NEGATIVE_VALUE = re.compile(rf"^-(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?(?:\s*,\s*{_NUMBER})*$")


class SeamodemParser(argparse.ArgumentParser):
    """``argparse.ArgumentParser`` with the command line's conventions.

    - A mistake on the command line (unknown option, bad value, missing
      argument) is one line on stderr, ``seamodem CMD: error: argument
      --opt: problem (see seamodem CMD --help)``, and exit code 2: no usage block.
    - An unknown option is refused by the command's parser, so the message
      names the command (``seamodem rx: error: unrecognized arguments: ...``).
    - A value that starts with ``-`` and reads as a number or a list of numbers
      (``-45,25``, ``-1e-3``, ``-0.5``) is a value, so ``--beacon -45,25``
      works as ``--beacon=-45,25`` does.

    Subparsers made by ``add_subparsers`` are of the same class (argparse's
    default), so setting it on the top-level parser sets it everywhere.
    """

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = _NEGATIVE_VALUE

    def parse_known_args(self, args=None, namespace=None):
        """As argparse's; a command's own parser (no subcommands) refuses what it does not know, naming itself."""
        namespace, extras = super().parse_known_args(args, namespace)
        if extras and self._subparsers is None:
            self.error(f"unrecognized arguments: {' '.join(extras)}")
        return namespace, extras

    def error(self, message: str):
        """Print ``PROG: error: MESSAGE`` on one line and exit with code 2."""
        first = " ".join(str(message).split())
        self.exit(2, f"{self.prog}: error: {first} (see {self.prog} --help)\n")
