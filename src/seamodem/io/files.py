"""Atomic output: a set of files appears complete, or not at all."""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path

from ..errors import SeamodemError

__all__ = ["atomic_outputs", "check_writable"]


def check_writable(path: str | Path, *, parameter: str = "output") -> Path:
    """Fail early, before any work, if ``path`` cannot be written.

    Parameters
    ----------
    path : str or Path
        The output file to be written.
    parameter : str, optional
        Name of the option or argument given, for the error message.

    Returns
    -------
    Path
        ``path`` as a :class:`~pathlib.Path`.

    Raises
    ------
    SeamodemError
        Naming ``parameter`` and the path when its folder is missing or not writable.
    """
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    if path.is_dir():
        raise SeamodemError(f"{parameter}: {path} is a folder, not a file path")
    if not folder.is_dir():
        raise SeamodemError(f"{parameter}: folder {folder} does not exist")
    if not os.access(folder, os.W_OK):
        raise SeamodemError(f"{parameter}: folder {folder} is not writable")
    return path


@contextlib.contextmanager
def atomic_outputs(*paths: str | Path):
    """Yield temporary paths beside ``paths``; rename them over ``paths`` on success.

    On any exception the temporaries are deleted and nothing at ``paths`` changes,
    so a failed run never leaves a partial file that looks valid.

    Parameters
    ----------
    *paths : str or Path
        The final output files; their folders must exist.

    Yields
    ------
    list of Path
        One temporary file per path (``.<name>.*.part`` in the same folder),
        to be written inside the ``with`` block.
    """
    finals = [Path(p) for p in paths]
    temps = []
    try:
        for final in finals:
            fd, tmp = tempfile.mkstemp(prefix=f".{final.name}.", suffix=".part", dir=final.parent or ".")
            os.close(fd)
            temps.append(Path(tmp))
        yield temps
        umask = os.umask(0)
        os.umask(umask)
        for tmp, final in zip(temps, finals):
            os.chmod(tmp, 0o666 & ~umask)  # mkstemp creates 0600; give the usual permissions
            os.replace(tmp, final)
    except BaseException:
        for tmp in temps:
            with contextlib.suppress(FileNotFoundError):
                tmp.unlink()
        raise
