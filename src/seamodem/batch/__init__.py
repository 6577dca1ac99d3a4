"""Scale out: many recordings, long recordings and parameter sweeps on local processes or Dask.

:func:`run_tasks` is the one execution mechanism (serial, a local process
pool, or a Dask cluster); :func:`decode_files` decodes recordings whole or in
overlapping segments on it, with a resumable manifest of finished parts. See
``docs/batch.md``.
"""

from .decode import (
    BatchResult,
    PartFailure,
    Recording,
    decode_files,
    decode_part,
    min_overlap_s,
    plan_parts,
)
from .runner import BACKENDS, TaskResult, default_workers, map_tasks, run_tasks

__all__ = [
    "BACKENDS",
    "TaskResult",
    "default_workers",
    "run_tasks",
    "map_tasks",
    "Recording",
    "BatchResult",
    "PartFailure",
    "decode_files",
    "decode_part",
    "plan_parts",
    "min_overlap_s",
]
