"""``rx --array``: the hydrophone-array path of ``seamodem rx`` (kept here so rx.py only branches to it)."""

from __future__ import annotations

from typing import Any


def load_array(spec: str):
    """The array ``--array SPEC`` names (as ``seamodem channel --array``).

    Parameters
    ----------
    spec : str
        File or inline specification (docs/array.md).

    Returns
    -------
    seamodem.channel.array.ReceiverArray
    """
    from ..channel.array import load_array as load

    return load(spec)


def array_records(array, inputs) -> list:
    """Records of every frame of a multichannel recording, with the direction of arrival (receive.array).

    Parameters
    ----------
    array : ReceiverArray
        From :func:`load_array`.
    inputs : seamodem.cli.rx._Inputs
        The recording and what its receiver needs.

    Returns
    -------
    list of MeasurementRecord
    """
    from ..receive.array import receive_array_file

    return receive_array_file(inputs.source, inputs.config, array.element_positions_m, emissions=inputs.emissions,
                              settings=inputs.settings, complex_gains=array.complex_gains,
                              position_sigma_m=array.position_sigma_m, pilot=inputs.pilot,
                              payloads=inputs.payloads, assume=array.assume)


def array_header(array, spec: str) -> dict[str, Any]:
    """The array as the receiver assumed it, for the measurement sidecar.

    Parameters
    ----------
    array : ReceiverArray
        From :func:`load_array`.
    spec : str
        ``--array`` as given.

    Returns
    -------
    dict
        ``{"array": {...}}``.
    """
    from ..receive.array import array_geometry

    geometry = array_geometry(array.element_positions_m, array.assume)
    return {"array": {"spec": spec, **array.to_dict(), "geometry": geometry.kind, "assume": geometry.assume or None,
                      "ambiguity": geometry.ambiguity or None,
                      "note": "the receiver uses the nominal element positions and removes gain_db/phase_rad"}}
