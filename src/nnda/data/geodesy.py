"""A local east-north-up (ENU) tangent plane on the WGS 84 ellipsoid, about a named origin.

Usage sketch::

    o = GeodeticOrigin(51.47, -0.45)                 # lat deg, lon deg (alt m, default 0)
    x, y, up = o.to_local(lat, lon, alt)             # m east, m north, m up; arrays of one shape
    lat, lon, alt = o.to_geodetic(x, y, up)          # the inverse
    lat, lon = o.on_surface(x, y)                    # the point at (x, y) east/north at the origin's height

nnda's scene frame is this plane (x east, y north, m): geodetic input is
placed on it at import, and tracks leave it with their latitude and
longitude. The transform is PROJ's topocentric conversion (geodetic ->
geocentric -> ENU, by pyproj); nothing here does ellipsoid arithmetic
itself. Up is dropped by the 2-D trackers: `on_surface` puts a plane point
back at a chosen ellipsoidal height, which inverts `to_local` exactly for a
point at that height.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from nnda.errors import ConfigError, NndaError

#: an import refuses an altitude (m) of a larger magnitude (a unit error)
MAX_ALTITUDE_M = 1e8
#: `on_surface` stops when the height is this close to the one asked for, m ...
SURFACE_TOLERANCE_M = 1e-6
#: ... or after this many steps (each moves along the plane's up axis by the height's error)
SURFACE_STEPS = 8


def _field(name: str, row: int) -> str:
    """Where a bad value lies when the caller names nothing better: ``lat[3]``."""
    return f"{name}[{row}]"


def check_geodetic(lat, lon, alt=None, *, where: Callable[[str, int], str] = _field,
                   error: type[NndaError] = ConfigError) -> None:
    """Raise ``error`` at the first latitude outside [-90, 90] deg, longitude outside [-180, 360) deg, or
    value that is not finite (``alt``, m, may be None). ``where(field, index)`` names the value (a file, row
    and column at import; ``lat[3]`` by default); ``field`` is one of "lat", "lon", "alt"."""
    checks = (("lat", lat, -90.0, 90.0, "[-90, 90] deg"), ("lon", lon, -180.0, 360.0, "[-180, 360) deg"),
              ("alt", alt, -MAX_ALTITUDE_M, MAX_ALTITUDE_M, f"+-{MAX_ALTITUDE_M:g} m (another unit?)"))
    for name, values, low, high, shown in checks:
        if values is None:
            continue
        a = np.atleast_1d(np.asarray(values, dtype=float))
        bad = ~np.isfinite(a)
        if bad.any():
            i = int(np.argmax(bad))
            raise error(f"{where(name, i)}: {float(a[i])!r} ({name} must be a finite number)")
        bad = (a < low) | (a > high) | ((a == high) & (name == "lon"))
        if bad.any():
            i = int(np.argmax(bad))
            raise error(f"{where(name, i)}: {name} {float(a[i])!r} is outside {shown}")


@dataclass(frozen=True)
class GeodeticOrigin:
    """The origin of the local plane: latitude and longitude (deg, WGS 84) and ellipsoidal height (m).

    ``source`` says how it was chosen (shown by the import; kept in the
    dataset's manifest). The east axis points along increasing longitude,
    the north axis along increasing latitude, at the origin.
    """

    lat_deg: float
    lon_deg: float
    alt_m: float = 0.0
    source: str = "given"

    def __post_init__(self) -> None:
        check_geodetic(self.lat_deg, self.lon_deg, self.alt_m, where=lambda name, _: f"geodetic origin {name}")
        if abs(self.lat_deg) == 90.0:
            raise ConfigError(f"geodetic origin lat {self.lat_deg!r}: a pole has no east or north; choose an origin "
                              f"off the pole")

    @cached_property
    def _pipeline(self):
        """PROJ's geodetic (lon deg, lat deg, h m) -> ENU (m) pipeline about this origin."""
        from pyproj import Transformer

        return Transformer.from_pipeline(
            "+proj=pipeline +step +proj=unitconvert +xy_in=deg +xy_out=rad "
            "+step +proj=cart +ellps=WGS84 "
            f"+step +proj=topocentric +ellps=WGS84 +lat_0={self.lat_deg!r} +lon_0={self.lon_deg!r} "
            f"+h_0={self.alt_m!r}")

    def to_local(self, lat, lon, alt=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """ENU coordinates (x east, y north, up; m) of points at ``lat``, ``lon`` (deg) and ellipsoidal height
        ``alt`` (m; None: the origin's height); arrays broadcast to one shape. Unchecked: see
        `check_geodetic`."""
        lat, lon = np.asarray(lat, dtype=float), np.asarray(lon, dtype=float)
        alt = np.full(np.broadcast(lat, lon).shape, self.alt_m) if alt is None else np.asarray(alt, dtype=float)
        lat, lon, alt = np.broadcast_arrays(lat, lon, alt)
        x, y, up = self._pipeline.transform(lon, lat, alt)
        return np.asarray(x, dtype=float), np.asarray(y, dtype=float), np.asarray(up, dtype=float)

    def to_geodetic(self, x, y, up=0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Latitude, longitude (deg; longitude in [-180, 180]) and ellipsoidal height (m) of the points
        ``x`` east, ``y`` north and ``up`` (m) of the plane; arrays broadcast to one shape."""
        from pyproj.enums import TransformDirection

        x, y, up = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (x, y, up)))
        lon, lat, alt = self._pipeline.transform(x, y, up, direction=TransformDirection.INVERSE)
        return np.asarray(lat, dtype=float), np.asarray(lon, dtype=float), np.asarray(alt, dtype=float)

    def on_surface(self, x, y, alt=None) -> tuple[np.ndarray, np.ndarray]:
        """Latitude and longitude (deg) of the point ``x`` east, ``y`` north (m) of the plane at ellipsoidal
        height ``alt`` (m; None: the origin's): the inverse of `to_local` once up is dropped. Found by moving
        along the plane's up axis by the height's error until within `SURFACE_TOLERANCE_M`."""
        x, y = np.broadcast_arrays(np.asarray(x, dtype=float), np.asarray(y, dtype=float))
        target = self.alt_m if alt is None else np.asarray(alt, dtype=float)
        up = np.zeros(x.shape)
        for _ in range(SURFACE_STEPS):
            lat, lon, h = self.to_geodetic(x, y, up)
            miss = h - target
            if not np.any(np.abs(miss) > SURFACE_TOLERANCE_M):
                break
            up = up - miss
        return lat, lon

    def record(self) -> dict:
        """The manifest's ``geodetic_origin``: lat_deg, lon_deg, alt_m, source."""
        return {"lat_deg": self.lat_deg, "lon_deg": self.lon_deg, "alt_m": self.alt_m, "source": self.source}

    def __str__(self) -> str:
        return f"lat {self.lat_deg:.6f} deg, lon {self.lon_deg:.6f} deg, alt {self.alt_m:g} m ({self.source})"


def parse_origin(value, option: str = "--origin") -> GeodeticOrigin:
    """``"LAT,LON[,ALT]"`` (deg, deg, m), a sequence of 2 or 3 numbers, or a `GeodeticOrigin`, as a checked
    origin; ConfigError naming ``option``, the value and the form otherwise."""
    if isinstance(value, GeodeticOrigin):
        return value
    form = f"give {option} LAT,LON or LAT,LON,ALT (degrees, degrees, m), e.g. {option} 51.4700,-0.4543,25"
    parts = value.split(",") if isinstance(value, str) else list(value) if isinstance(value, (list, tuple)) else None
    if parts is None or len(parts) not in (2, 3):
        raise ConfigError(f"{option} {value!r}: {form}")
    try:
        numbers = [float(p) for p in parts]
    except (TypeError, ValueError):
        raise ConfigError(f"{option} {value!r}: not numbers; {form}") from None
    try:
        return GeodeticOrigin(*numbers, source=f"the {option} option" if option.startswith("--") else option)
    except ConfigError as exc:
        raise ConfigError(f"{option} {value!r}: {str(exc).removeprefix('geodetic origin ')}; {form}") from None


def mean_position(lat: np.ndarray, lon: np.ndarray, digits: int = 4) -> tuple[float, float]:
    """The mean latitude and the circular mean longitude (deg) of points, rounded to ``digits`` decimals (a
    longitude in [-180, 180)); the points must not be empty."""
    rad = np.radians(lon)
    mean_lon = math.degrees(math.atan2(float(np.sin(rad).mean()), float(np.cos(rad).mean())))
    mean_lon = (mean_lon + 180.0) % 360.0 - 180.0
    return round(float(np.mean(lat)), digits), round(mean_lon, digits)
