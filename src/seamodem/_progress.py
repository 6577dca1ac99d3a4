"""Progress bars for long work (tqdm on stderr, shown only on a terminal by default)."""

from __future__ import annotations

__all__ = ["progress_bar"]


def progress_bar(*, total: int, desc: str, enabled: bool | None = None, **kwargs):
    """A tqdm bar; ``enabled=None`` shows it only when stderr is a terminal."""
    from tqdm.auto import tqdm  # imported here: a command that draws no bar does not wait for it

    return tqdm(total=total, desc=desc, disable=(None if enabled is None else not enabled), leave=False, **kwargs)
