"""[water]: the sound-speed profile a geometry scenario's rays are traced through.

Either a cast file (``profile = "ctd.csv"``, read by :func:`seamodem.water.read_profile`:
depth and c, or depth/pressure, temperature and salinity through TEOS-10) or the
profile inline (``depth_m = [...]``, ``c_mps = [...]``). With it the paths of
:class:`~seamodem.channel.raytraced.RayTracedModel` are traced eigenrays, so
delays show refraction and each path's Doppler follows its ray's angles.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ..errors import ConfigError, SeamodemError
from ..water import SoundSpeedProfile, read_profile
from .scenario_sections import Section

__all__ = ["Water"]


@dataclass(frozen=True, kw_only=True)
class Water(Section):
    """[water]: a sound-speed profile.

    Parameters
    ----------
    profile : str, optional
        A cast file (CSV), relative to the scenario's folder.
    depth_m, c_mps : list of float, optional
        The profile inline: node depths [m] (positive down, increasing) and sound speeds [m/s].
    latitude_deg : float
        The cast's latitude [deg] (pressure ↔ depth, TEOS-10).
    formula : {"teos10", "mackenzie"}
        How a CTD cast's temperature and salinity become c.
    """

    SECTION = "water"
    profile: str | None = None
    depth_m: list | None = None
    c_mps: list | None = None
    latitude_deg: float = 45.0
    formula: str = "teos10"

    def __post_init__(self):
        inline = self.depth_m is not None or self.c_mps is not None
        if (self.profile is None) == (not inline) or (inline and (self.depth_m is None or self.c_mps is None)):
            raise ConfigError(self.SECTION, "give either profile = \"FILE.csv\" or both depth_m and c_mps")
        if inline:
            try:
                SoundSpeedProfile(self.depth_m, self.c_mps, source=self._name("depth_m"))
            except (TypeError, ValueError) as exc:
                if isinstance(exc, ConfigError):
                    raise
                raise ConfigError(self._name("depth_m"), f"depth_m and c_mps must be lists of numbers ({exc})") from None

    def sound_speed_profile(self, base_dir: str | Path = ".") -> SoundSpeedProfile:
        """The profile, read from its file (relative to ``base_dir``) or built from the inline lists."""
        if self.profile is None:
            return SoundSpeedProfile(self.depth_m, self.c_mps, source="[water] inline")
        try:
            return read_profile(Path(base_dir) / self.profile, formula=self.formula, latitude_deg=self.latitude_deg)
        except SeamodemError as exc:
            raise ConfigError(self._name("profile"), str(exc)) from None
