"""Terrain maps of the walker simulator of Frencl (2014), Secs. 4.1-4.2: regions on a grid, waypoints, their links.

Format (our choice; the thesis draws its maps as colour-coded images): a
TOML (or JSON) file of axis-aligned boxes painted in order on a grid of
square cells, which keeps a map readable, diffable and exact in metres::

    name = "plus"
    width_m = 48.0            # x from 0 (west) to width_m (east), m
    height_m = 48.0           # y from 0 (south) to height_m (north), m
    cell_m = 1.0              # square cells; width and height are whole numbers of cells
    background = "free"       # the kind of every cell no region covers

    [[regions]]               # painted in file order; a later box covers an earlier one
    kind = "obstacle"         # obstacle | difficult | easy | free | generator | sink
    box = [0.0, 0.0, 18.0, 18.0]      # [x_min, y_min, x_max, y_max], m

    [[regions]]
    kind = "generator"        # generators and sinks are named; a generator lists where its
    name = "south-door"       # walkers head first (waypoints or sinks)
    box = [18.0, 0.0, 30.0, 2.0]
    accessible = ["centre"]

    [[waypoints]]             # the thesis's sub-destinations (cyan points)
    name = "centre"
    x_m = 24.0
    y_m = 24.0
    radius_m = 3.0            # capture radius: inside it, the walker picks its next waypoint
    accessible = ["north", "east", "west"]

The thesis's colours map onto the kinds: red obstacle, yellow difficult,
blue easy, green free, magenta generator, black sink, cyan waypoints. A cell
belongs to a box when its centre does. The grid is ``kind_grid[row, col]``,
row 0 the southmost (y in [0, cell_m)), column 0 the westmost.

Checked when a map is built (`build_terrain`), each error naming the file and
the place (``regions[2]``, ``waypoints[0] 'centre'``): unknown kinds, boxes
outside the map or empty, a size that is not a whole number of cells,
missing or repeated names, links to unknown names, waypoints inside
obstacles or outside the map, no generator or no sink, a generator whose
cells have no path through passable cells to a sink, or whose links never
lead to a sink.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field
from scipy import ndimage

from nnda.errors import ConfigError, validated
from nnda.files import read_config

_STRICT = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)
PositiveFloat = Annotated[float, Field(gt=0, allow_inf_nan=False)]

TerrainKind = Literal["free", "easy", "difficult", "obstacle", "generator", "sink"]
#: terrain kinds in code order: ``kind_grid`` holds the index of a cell's kind in this tuple
KINDS: tuple[str, ...] = ("free", "easy", "difficult", "obstacle", "generator", "sink")
FREE, EASY, DIFFICULT, OBSTACLE, GENERATOR, SINK = range(6)
#: the thesis's colour of each kind (Table 4.1), for plots and for reading its figures
COLOURS = {"obstacle": "red", "difficult": "yellow", "easy": "blue", "free": "green",
           "generator": "magenta", "sink": "black"}
#: terrain facility f_t in [0, 1] of each kind: the chance factor of keeping walking on it (green 1 and
#: red 0 are the thesis's; blue 0.9 and yellow 0.6 are our defaults, the thesis gives none)
FACILITY: dict[str, float] = {"free": 1.0, "easy": 0.9, "difficult": 0.6, "obstacle": 0.0,
                              "generator": 1.0, "sink": 1.0}


class Region(BaseModel):
    """One box of terrain: its kind, its extent [x_min, y_min, x_max, y_max] m; generators and sinks named."""

    model_config = _STRICT

    kind: TerrainKind
    box: tuple[float, float, float, float]
    name: Annotated[str, Field(min_length=1)] | None = None
    accessible: list[str] = Field(default_factory=list, description="a generator's first destinations")


class Waypoint(BaseModel):
    """A sub-destination: position (m), capture radius (m) and the names it leads on to."""

    model_config = _STRICT

    name: Annotated[str, Field(min_length=1)]
    x_m: float
    y_m: float
    radius_m: PositiveFloat
    accessible: Annotated[list[str], Field(min_length=1)]


class TerrainMap(BaseModel):
    """A map file's content (see the module docstring); `build_terrain` rasterises and checks it."""

    model_config = _STRICT

    name: Annotated[str, Field(min_length=1, pattern=r"^[A-Za-z0-9_.\-]+$")]
    width_m: PositiveFloat
    height_m: PositiveFloat
    cell_m: PositiveFloat = 1.0
    background: TerrainKind = "free"
    regions: list[Region] = Field(default_factory=list)
    waypoints: list[Waypoint] = Field(default_factory=list)


@dataclass(frozen=True)
class Terrain:
    """A checked map on its grid and its destination graph.

    ``kind_grid`` (n_rows, n_cols) int8 indexes `KINDS`; ``facility`` (n_rows,
    n_cols) is f_t per cell. Nodes are the waypoints, then the sinks, then the
    generators, in file order: ``node_names`` (N,), ``node_xy`` (N, 2) m
    (a waypoint's position, a region's box centre), ``node_radius`` (N,) m
    (a waypoint's capture radius, 0 for regions), ``node_is_sink`` (N,) bool,
    ``links`` (N, N) bool (row i: where node i leads), ``reach_sink`` (N, S)
    bool (sink s can be reached from node i by following links).
    ``generator_cells`` and ``sink_region`` index generators and sinks.
    """

    map: TerrainMap
    source: str
    kind_grid: np.ndarray
    facility: np.ndarray
    node_names: tuple[str, ...]
    node_xy: np.ndarray
    node_radius: np.ndarray
    node_is_sink: np.ndarray
    links: np.ndarray
    reach_sink: np.ndarray
    generator_nodes: np.ndarray
    sink_nodes: np.ndarray
    generator_cells: tuple[np.ndarray, ...]

    @property
    def cell_m(self) -> float:
        return self.map.cell_m

    @property
    def shape(self) -> tuple[int, int]:
        """(n_rows, n_cols) of the grid."""
        return self.kind_grid.shape

    @property
    def area_m2(self) -> float:
        return self.map.width_m * self.map.height_m

    def cell_of(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(row, col, inside) of positions (m), any shape; row and col are clipped into the grid, ``inside``
        says whether the position lies on the map."""
        c = self.map.cell_m
        col, row = np.floor(np.asarray(x) / c).astype(np.intp), np.floor(np.asarray(y) / c).astype(np.intp)
        n_rows, n_cols = self.shape
        inside = (row >= 0) & (row < n_rows) & (col >= 0) & (col < n_cols)
        return np.clip(row, 0, n_rows - 1), np.clip(col, 0, n_cols - 1), inside

    def kind_at(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Kind index (`KINDS`) of the cells at positions (m); positions off the map read as obstacle."""
        row, col, inside = self.cell_of(x, y)
        return np.where(inside, self.kind_grid[row, col], OBSTACLE)


def _whole_cells(length: float, cell: float) -> int | None:
    n = length / cell
    return round(n) if math.isclose(n, round(n), rel_tol=0, abs_tol=1e-9) and round(n) > 0 else None


def build_terrain(m: TerrainMap, source: str = "<map>") -> Terrain:
    """Rasterise and check a map; ConfigError naming ``source`` and the place otherwise (module docstring)."""
    where = f"{source}: map {m.name!r}"
    n_cols, n_rows = _whole_cells(m.width_m, m.cell_m), _whole_cells(m.height_m, m.cell_m)
    if n_cols is None or n_rows is None:
        raise ConfigError(f"{where}: width_m x height_m = {m.width_m:g} x {m.height_m:g} m is not a whole number of "
                          f"square cells of cell_m = {m.cell_m:g} m")
    grid = np.full((n_rows, n_cols), KINDS.index(m.background), dtype=np.int8)
    centres_x = (np.arange(n_cols) + 0.5) * m.cell_m
    centres_y = (np.arange(n_rows) + 0.5) * m.cell_m
    names: dict[str, str] = {}
    masks: dict[int, np.ndarray] = {}
    for i, r in enumerate(m.regions):
        place = f"{where}: regions[{i}] ({r.kind}{' ' + repr(r.name) if r.name else ''})"
        x0, y0, x1, y1 = r.box
        if not (x0 < x1 and y0 < y1):
            raise ConfigError(f"{place}: box {list(r.box)} is empty; give [x_min, y_min, x_max, y_max] with "
                              f"x_min < x_max and y_min < y_max")
        if x0 < 0 or y0 < 0 or x1 > m.width_m or y1 > m.height_m:
            raise ConfigError(f"{place}: box {list(r.box)} leaves the map [0, 0, {m.width_m:g}, {m.height_m:g}]")
        cols = (centres_x > x0) & (centres_x < x1)
        rows = (centres_y > y0) & (centres_y < y1)
        if not cols.any() or not rows.any():
            raise ConfigError(f"{place}: box {list(r.box)} holds no cell centre of the {m.cell_m:g} m grid")
        mask = rows[:, None] & cols[None, :]
        grid[mask] = KINDS.index(r.kind)
        if r.kind in ("generator", "sink"):
            if r.name is None:
                raise ConfigError(f"{place}: a {r.kind} needs a name")
            if r.name in names:
                raise ConfigError(f"{place}: the name {r.name!r} is already taken by {names[r.name]}")
            names[r.name] = f"regions[{i}]"
            masks[i] = mask
            if r.kind == "generator" and not r.accessible:
                raise ConfigError(f"{place}: a generator lists in `accessible` where its walkers head first")
        elif r.name is not None or r.accessible:
            raise ConfigError(f"{place}: only generators and sinks take a name and generators `accessible`")
    for j, w in enumerate(m.waypoints):
        if w.name in names:
            raise ConfigError(f"{where}: waypoints[{j}] {w.name!r}: the name is already taken by {names[w.name]}")
        names[w.name] = f"waypoints[{j}]"

    sinks = [i for i, r in enumerate(m.regions) if r.kind == "sink"]
    generators = [i for i, r in enumerate(m.regions) if r.kind == "generator"]
    for what, found in (("generator", generators), ("sink", sinks)):
        if not found:
            raise ConfigError(f"{where}: the map has no {what} region (kind = \"{what}\"); walkers are born at "
                              f"generators and leave at sinks")
    for i in (*sinks, *generators):  # a later box may have painted over a whole generator or sink
        masks[i] &= grid == KINDS.index(m.regions[i].kind)
        if not masks[i].any():
            raise ConfigError(f"{where}: regions[{i}] ({m.regions[i].kind} {m.regions[i].name!r}) is wholly "
                              f"covered by later regions")

    node_names = tuple([w.name for w in m.waypoints] + [m.regions[i].name for i in (*sinks, *generators)])
    index = {n: k for k, n in enumerate(node_names)}
    xy = [(w.x_m, w.y_m) for w in m.waypoints]
    xy += [((m.regions[i].box[0] + m.regions[i].box[2]) / 2, (m.regions[i].box[1] + m.regions[i].box[3]) / 2)
           for i in (*sinks, *generators)]
    n = len(node_names)
    links = np.zeros((n, n), dtype=bool)
    sources = [(f"waypoints[{j}] {w.name!r}", w.accessible) for j, w in enumerate(m.waypoints)]
    sources += [(None, [])] * len(sinks)
    sources += [(f"regions[{i}] (generator {m.regions[i].name!r})", m.regions[i].accessible) for i in generators]
    generator_names = {m.regions[i].name for i in generators}
    for k, (place, targets) in enumerate(sources):
        for t in targets:
            if t not in index:
                raise ConfigError(f"{where}: {place}: accessible names {t!r}, which is no waypoint or sink of the "
                                  f"map (names: {', '.join(x for x in node_names if x not in generator_names)})")
            if t in generator_names:
                raise ConfigError(f"{where}: {place}: accessible names the generator {t!r}; walkers head for "
                                  f"waypoints and sinks")
            links[k, index[t]] = True

    kinds_here = np.array([grid[int(r), int(c)] if 0 <= r < n_rows and 0 <= c < n_cols else OBSTACLE
                           for r, c in ((math.floor(y / m.cell_m), math.floor(x / m.cell_m)) for x, y in xy)])
    for j, w in enumerate(m.waypoints):
        if not (0 <= w.x_m <= m.width_m and 0 <= w.y_m <= m.height_m):
            raise ConfigError(f"{where}: waypoints[{j}] {w.name!r} at ({w.x_m:g}, {w.y_m:g}) m lies off the map")
        if kinds_here[j] == OBSTACLE:
            r, c = math.floor(w.y_m / m.cell_m), math.floor(w.x_m / m.cell_m)
            raise ConfigError(f"{where}: waypoints[{j}] {w.name!r} at ({w.x_m:g}, {w.y_m:g}) m lies inside an "
                              f"obstacle (grid row {r}, column {c})")

    # reachability through links (transitive closure) and through passable cells
    reach = links | np.eye(n, dtype=bool)
    for _ in range(n):
        nxt = reach | ((reach.astype(np.int32) @ reach.astype(np.int32)) > 0)
        if np.array_equal(nxt, reach):
            break
        reach = nxt
    sink_nodes = np.arange(len(m.waypoints), len(m.waypoints) + len(sinks))
    generator_nodes = np.arange(len(m.waypoints) + len(sinks), n)
    labels, _ = ndimage.label(grid != OBSTACLE)
    sink_labels = set(np.unique(np.concatenate([labels[masks[i]] for i in sinks])).tolist())
    for g_node, i in zip(generator_nodes, generators):
        place = f"{where}: regions[{i}] (generator {m.regions[i].name!r})"
        if not reach[g_node, sink_nodes].any():
            raise ConfigError(f"{place}: following `accessible` from it never leads to a sink")
        if not set(np.unique(labels[masks[i]]).tolist()) & sink_labels:
            raise ConfigError(f"{place}: no path through passable cells leads from it to a sink "
                              f"(obstacles wall it in)")

    facility = np.array([FACILITY[k] for k in KINDS])[grid]
    return Terrain(
        map=m, source=source, kind_grid=grid, facility=facility, node_names=node_names,
        node_xy=np.array(xy, dtype=float), node_radius=np.array([w.radius_m for w in m.waypoints] + [0.0] * (
            len(sinks) + len(generators))), node_is_sink=np.isin(np.arange(n), sink_nodes), links=links,
        reach_sink=reach[:, sink_nodes], generator_nodes=generator_nodes, sink_nodes=sink_nodes,
        generator_cells=tuple(np.argwhere(masks[i]) for i in generators))


def terrain_from_dict(data: dict, source: str = "<map>") -> Terrain:
    """Validate a mapping as a `TerrainMap` and build it; errors name ``source`` and the field."""
    return build_terrain(validated(TerrainMap, data, source, "terrain map"), source)


def load_map(path: str | Path) -> Terrain:
    """Read, validate and build a map file (``.toml`` or ``.json``; the module docstring gives the format)."""
    return terrain_from_dict(read_config(path, "terrain map"), str(path))
