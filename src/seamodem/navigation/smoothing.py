"""Former name of :mod:`seamodem.navigation.inertial.smoothers`, the inertial filter's batch and fixed-lag smoothers.

Kept so that ``from seamodem.navigation.smoothing import batch_smooth`` keeps working.
"""

from .inertial.smoothers import SMOOTHER_POSITION_RW, SmoothedTrack, batch_smooth, fixed_lag_smooth

__all__ = ["SMOOTHER_POSITION_RW", "SmoothedTrack", "batch_smooth", "fixed_lag_smooth"]
