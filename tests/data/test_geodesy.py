"""`nnda.data.geodesy`: the local east-north-up plane about a geodetic origin, against pyproj's geodesics."""

from __future__ import annotations

import numpy as np
import pytest
from pyproj import Geod

from nnda.data.geodesy import GeodeticOrigin, check_geodetic, mean_position, parse_origin
from nnda.errors import ConfigError, DatasetError

WGS84 = Geod(ellps="WGS84")
ORIGINS = [GeodeticOrigin(51.47, -0.4543, 25.0), GeodeticOrigin(-33.9, 151.2), GeodeticOrigin(64.0, 179.9, -40.0)]


@pytest.mark.parametrize("origin", ORIGINS, ids=str)
def test_round_trip_to_the_plane_and_back(origin):
    rng = np.random.default_rng(3)
    lat = origin.lat_deg + rng.uniform(-0.5, 0.5, 200)
    lon = origin.lon_deg + rng.uniform(-0.5, 0.5, 200)
    alt = rng.uniform(-100.0, 12000.0, 200)
    x, y, up = origin.to_local(lat, lon, alt)
    assert x.shape == y.shape == up.shape == (200,)
    back_lat, back_lon, back_alt = origin.to_geodetic(x, y, up)
    np.testing.assert_allclose(back_lat, lat, rtol=1e-9)
    np.testing.assert_allclose((back_lon - lon + 180.0) % 360.0 - 180.0, 0.0, atol=1e-9)
    np.testing.assert_allclose(back_alt, alt, atol=1e-6)
    # up dropped: on_surface puts the plane point back at the height it came from
    s_lat, s_lon = origin.on_surface(x, y, alt)
    np.testing.assert_allclose(s_lat, lat, rtol=1e-9)
    np.testing.assert_allclose((s_lon - lon + 180.0) % 360.0 - 180.0, 0.0, atol=1e-9)


@pytest.mark.parametrize("origin", ORIGINS, ids=str)
def test_distances_and_bearings_from_the_origin_match_the_geodesic_at_50_km(origin):
    bearings = np.arange(0.0, 360.0, 30.0)
    n = bearings.size
    lon, lat, _ = WGS84.fwd(np.full(n, origin.lon_deg), np.full(n, origin.lat_deg), bearings, np.full(n, 5e4))
    x, y, _ = origin.to_local(lat, lon, np.full(n, origin.alt_m))
    _, _, distance = WGS84.inv(np.full(n, origin.lon_deg), np.full(n, origin.lat_deg), lon, lat)
    assert np.all(np.abs(np.hypot(x, y) - distance) < 1.0)  # the chord's horizontal part, 0.5 m short at 50 km
    heading = np.degrees(np.arctan2(x, y)) % 360.0  # clockwise from north, as nnda's azimuths
    assert np.all(np.abs((heading - bearings + 180.0) % 360.0 - 180.0) < 0.01)


def test_the_axes_point_east_and_north():
    origin = GeodeticOrigin(45.0, 7.0)
    x, y, up = origin.to_local([45.0, 45.01, 45.0], [7.01, 7.0, 7.0], [0.0, 0.0, 100.0])
    assert x[0] > 780.0 and abs(y[0]) < 1.0  # 0.01 deg east of the origin: ~786 m east
    assert y[1] > 1100.0 and abs(x[1]) < 1e-6  # 0.01 deg north: ~1111 m north
    np.testing.assert_allclose([x[2], y[2], up[2]], [0.0, 0.0, 100.0], atol=1e-6)


def test_checks_name_the_field_and_value():
    with pytest.raises(ConfigError, match=r"lat\[1\]: lat 95.0 is outside \[-90, 90\]"):
        check_geodetic([10.0, 95.0], [0.0, 0.0])
    with pytest.raises(DatasetError, match=r"row 2: lon 360.0 is outside \[-180, 360\)"):
        check_geodetic([0.0, 0.0], [0.0, 360.0], where=lambda name, i: f"row {i + 1}", error=DatasetError)
    with pytest.raises(ConfigError, match=r"alt\[0\]: nan \(alt must be a finite number\)"):
        check_geodetic([0.0], [0.0], [np.nan])
    check_geodetic([-90.0, 90.0], [-180.0, 359.9])  # the limits themselves


@pytest.mark.parametrize(("value", "fragment"), [
    ("51.5", "give --origin LAT,LON or LAT,LON,ALT"),
    ("51.5,-0.1,2,3", "give --origin LAT,LON or LAT,LON,ALT"),
    ("north,-0.1", "not numbers"),
    ("91,0", "lat 91.0 is outside [-90, 90]"),
    ("10,400", "lon 400.0 is outside [-180, 360)"),
    ("90,0", "a pole has no east or north"),
    ("10,inf", "lon must be a finite number"),
])
def test_a_bad_origin_is_refused_naming_the_option(value, fragment):
    with pytest.raises(ConfigError, match=r"^--origin ") as err:
        parse_origin(value)
    assert fragment in str(err.value)


def test_an_origin_parsed_and_the_mean_position_across_the_antimeridian():
    o = parse_origin("51.47,-0.4543,25")
    assert (o.lat_deg, o.lon_deg, o.alt_m) == (51.47, -0.4543, 25.0) and "--origin" in o.source
    assert mean_position(np.array([10.0, 10.2]), np.array([179.9, -179.9])) == (10.1, -180.0)
    assert mean_position(np.array([1.0, 2.0]), np.array([3.00001, 3.00003])) == (1.5, 3.0)
