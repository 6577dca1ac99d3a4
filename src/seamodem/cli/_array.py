"""``rx --array``: the hydrophone-array path of ``seamodem rx`` (kept here so rx.py only branches to it)."""

from __future__ import annotations

import argparse
from typing import Any


def _array(args: argparse.Namespace):
    from ..channel.array import load_array

    return load_array(args.array)


def array_records(args: argparse.Namespace, inputs) -> list:
    """Records of every frame of a multichannel recording, with the direction of arrival (receive.array)."""
    from ..receive.array import receive_array_file

    array = _array(args)
    return receive_array_file(inputs.path, inputs.config, array.element_positions_m, emissions=inputs.emissions,
                              settings=inputs.settings, complex_gains=array.complex_gains,
                              position_sigma_m=array.position_sigma_m, pilot=inputs.pilot,
                              payloads=inputs.payloads, assume=array.assume)


def array_header(args: argparse.Namespace) -> dict[str, Any]:
    """The array as the receiver assumed it, for the measurement sidecar ({} without --array)."""
    if not getattr(args, "array", None):
        return {}
    from ..receive.array import array_geometry

    array = _array(args)
    geometry = array_geometry(array.element_positions_m, array.assume)
    return {"array": {"spec": args.array, **array.to_dict(), "geometry": geometry.kind, "assume": geometry.assume or None,
                      "ambiguity": geometry.ambiguity or None,
                      "note": "the receiver uses the nominal element positions and removes gain_db/phase_rad"}}
