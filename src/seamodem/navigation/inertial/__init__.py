"""The inertial beacon filter: IMU-driven dead reckoning, heading bias as a state, gated acoustic fixes.

Paper 000's filter treats the gyro and the accelerometer as *measurements* of
states (Ω, a) with a near-zero process noise (Q = Δt⁸), and the heading sensor
as unbiased. Told how good centimetre ranges are, it diverges (docs/navigation.md).
This filter is built the other way round, as navigation filters with an IMU are:

- the gyro and the accelerometer are *inputs* of the motion model, and the
  process noise is their stated noise density times the time step (a random
  walk in heading and speed), not a tuning constant;
- the heading sensor (AHRS, compass) measures ψ + b, with the bias b (and
  optionally its drift rate ḃ) in the state: paper 000 §5 names the heading
  (bearing) error as the dominant limit, and only the acoustic measurements can
  observe it;
- optionally a water current (c_x, c_y) [m/s] and a range scale s (a sound-speed
  error: range and v_r are both multiplied by 1 + s);
- the acoustic update (range, and v_r unless range-only) is an *iterated* EKF
  (Gauss–Newton on the posterior): with σ_d = 1 mm and a position prior of
  metres, one linearization of the range is off by more than the noise;
- every acoustic update is gated on its normalised innovation squared (χ² with
  1 or 2 degrees of freedom); a gated frame is reported, not silently used, and
  after ``gate_reset_after`` frames gated in a row the next one is accepted (a
  filter that has lost itself must not reject the truth for ever).

State layout: (x, y, ψ, v, b) always, then ḃ, (c_x, c_y), s when enabled
(:class:`InertialConfig`). Positions in the local east-north frame [m],
heading counter-clockwise from east [rad], v_r the closing speed (SPEC §1).

Charts: by default the filter carries the position as (ρ, β), horizontal
distance and bearing from the beacon, and switches to (x, y) only near the
beacon (``coordinates``). With centimetre ranges the posterior is a thin arc
of the range circle, metres long: a Gaussian in (ρ, β) is that arc, a
Gaussian in (x, y) is its tangent, which the truth leaves by σ_t²/2ρ, many
times σ_d. Every output (``FilterRun.states``, the smoothers' tracks) is
Cartesian; ``internal_states`` keep the chart of each node (``charts``).

The numerical core is a set of small numba kernels working on *nodes*: the
sorted union of the IMU sample times and the frame arrival times. From node
i − 1 to node i the state moves with the rates of the first IMU sample at or
after node i (the sample that covers that interval); a heading measurement and
an acoustic measurement may sit on any node. The filter, the batch smoother and
the fixed-lag smoother (:mod:`.smoothers`) share them.

The package reads as the filter's maths:

- :mod:`.config`: :class:`InertialConfig`, the χ² gates;
- :mod:`.models`: the motion (prediction) and the acoustic measurement, with their Jacobians;
- :mod:`.updates`: the measurement updates (heading, range and v_r, bearing, position fix), gates, speed floor;
- :mod:`.charts`: the Cartesian and polar charts and the changes between them;
- :mod:`.records`: the kernels' structured arguments (model, settings, node arrays, workspace);
- :mod:`.kernels`: the smoothing kernels (linearized pass, Rauch–Tung–Striebel, window re-linearization);
- :mod:`.filter`: the filter's loop over the nodes;
- :mod:`.nodes`: the nodes from IMU samples and frames;
- :mod:`.driver`: :func:`run_filter` and :class:`FilterRun`;
- :mod:`.smoothers`: the batch and fixed-lag smoothers.
"""

from .charts import POLAR_ENTER, POLAR_LEAVE, to_cartesian
from .config import CHI2_GATE, WINDOW_ITERATIONS, InertialConfig, state_names, with_options
from .driver import FilterRun, chart_nees, run_filter
from .filter import filter_nodes
from .nodes import Nodes, add_bearings, add_fixes, build_nodes

__all__ = [
    "InertialConfig",
    "Nodes",
    "FilterRun",
    "build_nodes",
    "add_fixes",
    "add_bearings",
    "run_filter",
    "state_names",
    "CHI2_GATE",
    "chart_nees",
    "to_cartesian",
]
