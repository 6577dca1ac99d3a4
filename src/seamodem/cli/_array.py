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


def array_records(array, inputs, *, segment_s: float | None = None):
    """Records of every frame of a multichannel recording, with the direction of arrival (receive.array).

    A file is received whole; a stream in overlapping segments, each record yielded once its frame is
    final (:func:`~seamodem.batch.live.segmented_records`, docs/live.md).

    Parameters
    ----------
    array : ReceiverArray
        From :func:`load_array`.
    inputs : seamodem.cli.rx._Inputs
        The recording and what its receiver needs.
    segment_s : float, optional
        A stream: new seconds between two runs of the receiver (default
        :data:`~seamodem.batch.live.DEFAULT_SEGMENT_S`).

    Returns
    -------
    list or iterator of MeasurementRecord
    """
    from ..receive.array import receive_array, receive_array_file
    from ..receive.array.receiver import open_array_source

    options = dict(settings=inputs.settings, complex_gains=array.complex_gains,
                   position_sigma_m=array.position_sigma_m, pilot=inputs.pilot, payloads=inputs.payloads,
                   assume=array.assume)
    if inputs.source.n_samples is not None:
        return receive_array_file(inputs.source, inputs.config, array.element_positions_m,
                                  emissions=inputs.emissions, **options)
    from ..batch.decode import guard_for, overlap_for
    from ..batch.live import DEFAULT_SEGMENT_S, on_stream_clock, segmented_records
    from ..receive.measure import frame_span_s

    source = open_array_source(inputs.source, array.element_positions_m, array.assume)
    config, s, fs = inputs.config, inputs.settings, float(source.sample_rate_hz)

    def receive(x, t0_s):
        records, _ = receive_array(x, fs, config, array.element_positions_m,
                                   emissions=inputs.emissions.shifted(t0_s), **options)
        return [on_stream_clock(r, t0_s) for r in records]

    span = frame_span_s(config, v_max_mps=s.v_max_mps, sound_speed_mps=s.sound_speed_mps)
    return segmented_records(source.blocks(list(range(source.n_channels))), fs, receive,
                             overlap_s=overlap_for(span, config.frame_duration_s),
                             guard_s=guard_for(config.frame_duration_s),
                             segment_s=DEFAULT_SEGMENT_S if segment_s is None else segment_s)


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
