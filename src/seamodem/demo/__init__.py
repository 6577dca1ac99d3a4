"""The mission demo: one vehicle positioned from the very frames it decodes (``seamodem demo``).

The whole chain, offline, in well under a minute:

1. **vehicle** — a short boustrophedon survey (:mod:`seamodem.navigation.trajectories`),
   followed by the unicycle of paper 000 eq 3–4 under the controller of eq 2
   (:mod:`seamodem.navigation.vehicle`), at Δt = 0.25 s, with its IMU/AHRS
   (heading with white noise and a drifting bias, gyro, accelerometer);
2. **beacon** — a fixed beacon emits a jmse2024 frame every T_com
   (:func:`seamodem.transmit.write_beacon`), or with ``waveform="janus"``
   (``seamodem demo --waveform janus``) a JANUS packet received in step 4 by the
   JANUS receiver (:mod:`.janus`);
3. **channel** — the simulator (:func:`seamodem.channel.simulate_file`) makes the
   hydrophone recording along the vehicle's true track: geometry-driven Doppler
   on every path, surface and bottom echoes, spreading and absorption, white
   noise at a stated in-band SNR, and the truth of every frame;
4. **receiver** — :func:`seamodem.receive.receive_file` detects every frame,
   measures range and closing speed, and decodes the payload;
5. **navigation** — the inertial filter (IMU as input, heading bias as a state) and
   its batch smoother, beside the 6-state EKF of paper 000 ("proposed": range + v_r)
   and its range-only baseline ("rosb"), position the vehicle from those records
   plus the IMU (:func:`seamodem.navigation.track.run_track`);
6. **emulated twin** — the same mission, the same IMU samples, but range and v_r
   emulated from the geometry with the noise levels the receiver actually
   showed (its RMS errors against the truth): what a simulation without the
   waveform would predict.
7. **hydrophone array** (``array``, ``seamodem demo --array SPEC``) — the same
   beacon recorded by a small array on the vehicle (:func:`seamodem.channel.array.simulate_array`,
   the same SNR per element), received with :func:`seamodem.receive.array.receive_array`
   (detection and decoding on all channels, direction of arrival per frame)
   beside one of its hydrophones alone: frames found and decoded, range, the
   beacon's body azimuth against the truth, and the position of a one-frame
   fix (range + body azimuth + the AHRS heading + depth) with no filter.

Every step is a function (:mod:`.mission`), so ``examples/mission_demo.py`` can run
them one by one. :func:`run_demo` chains them and writes the outputs; :mod:`.summary`
makes the summary and its printed text, :mod:`.figures` the figures, :mod:`.config`
holds :class:`DemoConfig`.
"""

from .config import FILTER_COLOURS, FILTER_LABELS, FILTERS, DemoConfig, VehicleRun, receiver_settings
from .figures import plot_constellation, plot_errors, plot_map, plot_psd
from .mission import (DemoResult, array_mission, emit_and_propagate, emulate_measurements,
                      measurement_errors, make_scenario, navigate, receive, records_to_columns, run_demo,
                      simulate_vehicle, write_track_csv)
from .summary import format_summary

__all__ = [
    "DemoConfig",
    "VehicleRun",
    "DemoResult",
    "simulate_vehicle",
    "make_scenario",
    "emit_and_propagate",
    "receive",
    "measurement_errors",
    "navigate",
    "emulate_measurements",
    "run_demo",
    "array_mission",
    "format_summary",
]
