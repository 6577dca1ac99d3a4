"""Navigation: the papers' estimators as consumers of the receiver's measurements.

- :mod:`.ekf`: the filter interface (``predict(t_s, u)``, ``update(z, kind, R, t_s=)``)
  and the extended Kalman filter;
- :mod:`.models`: paper 000's 6-state model (proposed and ROSB), paper 002's
  4-state, paper 003's 3-state, paper 004's constant-velocity model;
- :mod:`.particle`: paper 001's particle filter; :mod:`.multilateration`: paper
  004's sequential anchor EKF and linear least squares;
- :mod:`.trajectories`, :mod:`.vehicle`, :mod:`.geometry`: simulation pieces;
- :mod:`.mission_config`, :mod:`.missions`: the simulated missions of paper 000 §4.1;
  :mod:`.montecarlo`: their Monte Carlo reproduction of paper 000 Tables 3–4;
- :mod:`.track`: tracking from measurement and IMU files (``seamodem nav track``).
"""

from .ekf import ExtendedKalmanFilter, kalman_update, nees
from .geometry import geodetic_to_local, local_to_geodetic, slant_to_horizontal
from .models import Auv3Model, Auv4Model, Auv6Model, ConstantVelocityModel, closing_speed
from .montecarlo import MissionConfig, NoiseModel, run_monte_carlo, simulate_mission
from .multilateration import lls_position, track_anchor_ranges
from .particle import ParticleFilter
from .trajectories import Lemniscate, boustrophedon, waypoint_path

__all__ = [
    "ExtendedKalmanFilter",
    "kalman_update",
    "nees",
    "geodetic_to_local",
    "local_to_geodetic",
    "slant_to_horizontal",
    "Auv3Model",
    "Auv4Model",
    "Auv6Model",
    "ConstantVelocityModel",
    "closing_speed",
    "MissionConfig",
    "NoiseModel",
    "run_monte_carlo",
    "simulate_mission",
    "lls_position",
    "track_anchor_ranges",
    "ParticleFilter",
    "Lemniscate",
    "boustrophedon",
    "waypoint_path",
]
