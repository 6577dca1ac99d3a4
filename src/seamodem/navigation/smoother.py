"""Former name of :mod:`seamodem.navigation.ekf_smoother`, the Rauch–Tung–Striebel smoother of an EKF's history.

Kept so that ``from seamodem.navigation.smoother import rts_smooth`` keeps working.
"""

from .ekf_smoother import rts_smooth

__all__ = ["rts_smooth"]
