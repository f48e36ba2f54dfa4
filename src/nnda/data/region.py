"""An area of interest at import (``nnda import-detections --region``): reports outside it are dropped.

A region is a box in the local frame (``xmin,ymin,xmax,ymax``, m), a box in
latitude and longitude (``lat:LAT0,LAT1,lon:LON0,LON1``, deg; LON1 < LON0
crosses the 180th meridian), or a polygon (its vertices in order, from a
file, `polygon_file`: x, y in m or lat, lon in deg). A geodetic region
needs the dataset's geodetic origin (`nnda.data.geodesy`); a polygon's
edges are straight lines in the local plane. Points on the boundary are
inside.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from nnda.data.geodesy import GeodeticOrigin, check_geodetic
from nnda.data.table_reading import (
    CsvDialect,
    decimal_mark,
    find_columns,
    numbers_of,
    read_table,
    require_columns,
    where_in,
)
from nnda.errors import ConfigError, DatasetError

#: ``lat:LAT0,LAT1,lon:LON0,LON1``
_GEODETIC_BOX = re.compile(r"\s*lat\s*:\s*([^,]+),([^,]+),\s*lon\s*:\s*([^,]+),([^,]+)\s*", re.IGNORECASE)
#: a polygon has at least this many distinct vertices
MIN_VERTICES = 3
KM = 1e-3


@dataclass(frozen=True)
class Region:
    """A box or polygon, in the local frame (m) or in degrees (``geodetic``); ``text`` as the user gave it.

    ``box``: (xmin, ymin, xmax, ymax) m, or (lat0, lat1, lon0, lon1) deg;
    ``vertices``: (K, 2) x, y m or lat, lon deg, K >= 3; one of the two.
    """

    text: str
    geodetic: bool
    box: tuple[float, float, float, float] | None = None
    vertices: np.ndarray | None = None

    def inside(self, x: np.ndarray, y: np.ndarray, origin: GeodeticOrigin | None) -> np.ndarray:
        """Which points (x east, y north, m; shape (N,)) lie in the region: bool (N,). A geodetic region
        needs ``origin`` (the caller checks: `needs_origin`)."""
        if self.box is not None and not self.geodetic:
            x0, y0, x1, y1 = self.box
            return (x >= x0) & (x <= x1) & (y >= y0) & (y <= y1)
        if self.box is not None:
            lat0, lat1, lon0, lon1 = self.box
            lat, lon = origin.on_surface(x, y)
            return (lat >= lat0) & (lat <= lat1) & ((lon - lon0) % 360.0 <= (lon1 - lon0) % 360.0)
        vx, vy = self.vertices[:, 0], self.vertices[:, 1]
        if self.geodetic:
            vx, vy, _ = origin.to_local(self.vertices[:, 0], self.vertices[:, 1])
        return in_polygon(x, y, vx, vy)

    def needs_origin(self) -> str:
        """The refusal of a geodetic region on data without a geodetic origin ("" when none)."""
        if not self.geodetic:
            return ""
        return (f"--region {self.text}: a region in latitude and longitude needs geodetic data (lat/lon columns "
                f"or sensor sites, or --origin LAT,LON); give the region in metres of the data's frame: "
                f"xmin,ymin,xmax,ymax or a polygon file with x, y columns")


def in_polygon(x: np.ndarray, y: np.ndarray, vx: np.ndarray, vy: np.ndarray) -> np.ndarray:
    """Points (x, y) (N,) inside the polygon of vertices (vx, vy) (K,), by the even-odd rule (crossings of a
    ray towards +x), or on an edge: bool (N,). One vectorised pass per edge."""
    inside = np.zeros(np.shape(x), dtype=bool)
    edge = np.zeros(np.shape(x), dtype=bool)
    for i in range(len(vx)):
        ax, ay, bx, by = vx[i - 1], vy[i - 1], vx[i], vy[i]
        straddles = (ay > y) != (by > y)
        with np.errstate(divide="ignore", invalid="ignore"):
            cross_x = ax + (y - ay) * (bx - ax) / (by - ay)
        inside ^= straddles & (x < cross_x)
        cross = (bx - ax) * (y - ay) - (by - ay) * (x - ax)
        scale = np.hypot(bx - ax, by - ay) * np.maximum(1.0, np.hypot(x - ax, y - ay))
        edge |= (np.abs(cross) <= 1e-12 * scale) & (x >= min(ax, bx)) & (x <= max(ax, bx)) \
            & (y >= min(ay, by)) & (y <= max(ay, by))
    return inside | edge


def _numbers(text: str, parts: list[str], form: str) -> list[float]:
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise ConfigError(f"--region {text}: not numbers; {form}") from None
    if not all(np.isfinite(values)):
        raise ConfigError(f"--region {text}: the numbers must be finite; {form}")
    return values


FORMS = ("give --region xmin,ymin,xmax,ymax (m, the data's frame), lat:LAT0,LAT1,lon:LON0,LON1 (deg), or a "
         "polygon file (.csv or .parquet) with x, y or lat, lon columns")


def parse_box(text: str) -> Region | None:
    """The box ``text`` gives (``xmin,ymin,xmax,ymax`` or ``lat:LAT0,LAT1,lon:LON0,LON1``), or None when it is
    no box (a polygon file's path); ConfigError for a malformed or empty box."""
    if m := _GEODETIC_BOX.fullmatch(text):
        lat0, lat1, lon0, lon1 = _numbers(text, list(m.groups()), FORMS)
        check_geodetic([lat0, lat1], [lon0, lon1], where=lambda name, _: f"--region {text}: {name}")
        if not lat0 < lat1:
            raise ConfigError(f"--region {text}: LAT0 {lat0:g} must be below LAT1 {lat1:g}")
        if (lon1 - lon0) % 360.0 == 0.0:
            raise ConfigError(f"--region {text}: LON0 and LON1 are the same meridian; give the box's west and "
                              f"east edges")
        return Region(text, True, box=(lat0, lat1, lon0, lon1))
    parts = text.split(",")
    if len(parts) == 4 and not re.search(r"[/\\]|\.(csv|parquet|pq)$", text, re.IGNORECASE):
        x0, y0, x1, y1 = _numbers(text, parts, FORMS)
        if not (x0 < x1 and y0 < y1):
            raise ConfigError(f"--region {text}: an empty box; xmin < xmax and ymin < ymax ({FORMS})")
        return Region(text, False, box=(x0, y0, x1, y1))
    if re.fullmatch(r"[\s\d.eE+-]+(,[\s\d.eE+-]+)+", text):
        raise ConfigError(f"--region {text}: {len(parts)} numbers; a box has 4: {FORMS}")
    if text.lower().startswith("lat") or (":" in text and not re.match(r"[a-zA-Z]:[/\\]", text)):
        raise ConfigError(f"--region {text}: unreadable; {FORMS}")
    return None


def polygon(text: str, a: np.ndarray, b: np.ndarray, geodetic: bool, path) -> Region:
    """The polygon of vertices ``a``, ``b`` (x, y m or lat, lon deg; (K,)) read from the file ``path``;
    DatasetError for fewer than `MIN_VERTICES` distinct vertices."""
    vertices = np.column_stack([a, b])
    if len(vertices) > 1 and np.array_equal(vertices[0], vertices[-1]):
        vertices = vertices[:-1]  # a closed ring written with its first vertex repeated
    distinct = len(np.unique(vertices, axis=0)) if len(vertices) else 0
    if distinct < MIN_VERTICES:
        raise DatasetError(f"--region {path}: a polygon needs at least {MIN_VERTICES} distinct vertices, the file "
                           f"has {distinct}; give one vertex per row, in order around the area")
    return Region(text, geodetic, vertices=vertices)


def parse_region(text: str | Path, dialect: CsvDialect = CsvDialect()) -> Region:
    """The region ``--region`` gives: a box (`parse_box`), else the polygon of the file at ``text``
    (`polygon_file`, a CSV read in ``dialect``)."""
    return parse_box(str(text)) or polygon_file(Path(text), dialect)


def polygon_file(path: Path, dialect: CsvDialect = CsvDialect()) -> Region:
    """The polygon of the ``--region`` file at ``path``: one vertex a row, columns x, y (m) or lat, lon (deg)."""
    table = read_table(path, "--region", dialect)
    present = find_columns(table, path, ("x", "y", "lat", "lon"), {})
    pair = ("x", "y") if {"x", "y"} <= present.keys() else ("lat", "lon")
    require_columns(path, present, pair, {}, table, "a polygon's vertices: x, y (m) or lat, lon (deg), one a row")
    a, b = (numbers_of(table, path, c, present[c], decimal_mark(path, dialect)) for c in pair)
    if pair[0] == "lat":
        check_geodetic(a, b, where=lambda c, row: where_in(path, row, present[c]), error=DatasetError)
    return polygon(str(path), a, b, pair[0] == "lat", path)


def extent(x: np.ndarray, y: np.ndarray, origin: GeodeticOrigin | None) -> str:
    """The data's extent for a message: x and y ranges (km), and latitude and longitude with an origin."""
    text = f"x {x.min() * KM:.3f}..{x.max() * KM:.3f} km, y {y.min() * KM:.3f}..{y.max() * KM:.3f} km"
    if origin is not None:
        lat, lon = origin.on_surface(x, y)
        text += f" (lat {lat.min():.5f}..{lat.max():.5f}, lon {lon.min():.5f}..{lon.max():.5f} deg)"
    return text
