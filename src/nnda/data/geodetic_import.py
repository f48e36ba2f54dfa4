"""Geodetic input to ``nnda import-detections``: sensor sites and reports in latitude and longitude, the
origin of the local frame, and ``--region``.

The importer (`nnda.data.detections_import`) reads the columns; this module
decides the frame and what falls outside the region:

* a sensor spec may give its site as ``lat``, ``lon`` (deg) and ``alt`` (m)
  instead of ``x_m``, ``y_m``; `sensor_sites` takes them out of the spec and
  `place_sites` writes the site's x_m, y_m on the local plane;
* the origin (`choose_origin`): the ``origin`` given (``--origin``), else
  the first sensor's site when it is geodetic, else the mean of the
  reports' latitudes and longitudes rounded to 1e-4 deg (height 0 m): of
  the reports kept when a region in degrees drops some (a region in metres
  is read on the plane of all the reports, which then stays);
* altitudes place each point on the plane (its east and north), then the
  2-D dataset drops them: `warn_altitude` says so once, counting the rows;
* `keep_in_region`: the rows inside ``--region``, with one BoundWarning
  counting those dropped, and an error when none is left.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from nnda.data.geodesy import GeodeticOrigin, check_geodetic, mean_position, parse_origin
from nnda.data.region import Region, extent
from nnda.errors import BoundWarning, ConfigError, DatasetError

#: the fields of a sensor spec that give its site in degrees (and metres of height)
SITE_FIELDS = ("lat", "lon", "alt")
#: digits (deg) of an origin chosen as the mean of the reports' positions
ORIGIN_DIGITS = 4


def sensor_sites(specs: Sequence[dict[str, Any]], names: Sequence[str]) -> list[tuple[float, float, float] | None]:
    """Each spec's geodetic site (lat deg, lon deg, alt m; alt None: 0) or None, the site fields taken out of
    the spec; ConfigError for a half-given site, a site given both ways, or values out of range."""
    sites: list[tuple[float, float, float] | None] = []
    for j, spec in enumerate(specs):
        given = {k: spec.pop(k) for k in SITE_FIELDS if k in spec}
        where = f"sensor {j} ({names[j]!r})"
        if not given:
            sites.append(None)
            continue
        if not {"lat", "lon"} <= given.keys():
            raise ConfigError(f"{where}: field(s) {', '.join(sorted(given))} given without "
                              f"{' and '.join(sorted({'lat', 'lon'} - given.keys()))}; a site in degrees needs "
                              f"lat and lon (alt optional, m)")
        if "x_m" in spec or "y_m" in spec:
            raise ConfigError(f"{where}: the site is given both as lat/lon and as x_m/y_m; give one of them")
        try:
            lat, lon, alt = (float(given.get(k, 0.0)) for k in SITE_FIELDS)
        except (TypeError, ValueError):
            raise ConfigError(f"{where}: lat, lon and alt must be numbers, got {given!r}") from None
        check_geodetic(lat, lon, alt, where=lambda name, _: f"{where}: field {name!r}")
        sites.append((lat, lon, alt))
    return sites


def choose_origin(given, sites: Sequence[tuple[float, float, float] | None], names: Sequence[str],
                  lat: np.ndarray | None, lon: np.ndarray | None) -> GeodeticOrigin | None:
    """The origin of the local frame (see the module), or None when nothing is geodetic; ConfigError when a
    later sensor's site is geodetic but neither the first sensor's nor the reports are, and no origin is
    given."""
    if given is not None:
        return parse_origin(given)
    if sites and sites[0] is not None:
        return GeodeticOrigin(*sites[0], source=f"the site of sensor {names[0]!r}")
    if lat is not None and lat.size:
        mean_lat, mean_lon = mean_position(lat, lon, ORIGIN_DIGITS)
        return GeodeticOrigin(mean_lat, mean_lon, 0.0, source="the mean of the reports' lat/lon")
    geodetic = [names[j] for j, s in enumerate(sites) if s is not None]
    if geodetic:
        raise ConfigError(f"sensor {geodetic[0]!r}: its site is given in lat/lon, but neither the first sensor's "
                          f"site nor the reports are: pass --origin LAT,LON to place the frame")
    return None


def place_sites(specs: Sequence[dict[str, Any]], sites: Sequence[tuple[float, float, float] | None],
                origin: GeodeticOrigin | None) -> None:
    """Write x_m, y_m (m) of each geodetic site on ``origin``'s plane into its spec (the site's height is
    dropped: nnda's sensors are 2-D)."""
    for spec, site in zip(specs, sites):
        if site is not None:
            x, y, _ = origin.to_local(*site)
            spec["x_m"], spec["y_m"] = float(x), float(y)


def warn_altitude(path: Path, column: str, n: int) -> None:
    """One BoundWarning: the altitudes of ``n`` rows of ``path`` placed the points, then were dropped."""
    if n:
        warnings.warn(f"{path}: column {column!r}: the altitudes of {n} row(s) place each point on the local "
                      f"plane and are then dropped (nnda tracks in 2-D: x east, y north)", BoundWarning,
                      stacklevel=3)


def local_positions(path: Path, present: Mapping[str, str], origin: GeodeticOrigin | None,
                    lat: np.ndarray, lon: np.ndarray, alt: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """x east, y north (m) on ``origin``'s plane of the checked points of ``path``, shape (N,); DatasetError
    without an origin."""
    if origin is None:
        raise DatasetError(f"{path}: columns {present['lat']!r}, {present['lon']!r} give positions in degrees, "
                           f"but the frame has no geodetic origin: pass --origin LAT,LON (or give the reports "
                           f"in lat/lon, or the first sensor's site as lat, lon)")
    x, y, _ = origin.to_local(lat, lon, alt)
    if alt is not None:
        warn_altitude(path, present["alt"], alt.size)
    return x, y


def keep_in_region(region: Region | None, x: np.ndarray, y: np.ndarray, origin: GeodeticOrigin | None
                   ) -> tuple[np.ndarray | None, int]:
    """Rows whose point (x, y m; (N,)) lies in ``region`` (bool (N,); None without a region) and how many
    are dropped; one BoundWarning when some are, ConfigError when all are (naming the data's extent)."""
    if region is None:
        return None, 0
    if region.geodetic and origin is None:
        raise ConfigError(region.needs_origin())
    keep = region.inside(x, y, origin)
    dropped = int(keep.size - keep.sum())
    if keep.size and not keep.any():
        raise ConfigError(f"--region {region.text}: excludes all {keep.size} reports, which span "
                          f"{extent(x, y, origin)}; give a region that overlaps the data")
    if dropped:
        warnings.warn(f"--region {region.text}: {dropped} of {keep.size} report(s) outside the region dropped "
                      f"(recorded in the dataset's manifest, field 'dropped_rows')", BoundWarning, stacklevel=3)
    return keep, dropped
