"""Bad terrain-map files of the walker simulator: a ConfigError naming the file and the place."""

from __future__ import annotations

import pytest

from dataset_edits import snapshot
from nnda.data.pedestrian.terrain import load_map
from nnda.errors import ConfigError

GOOD = """
name = "tiny"
width_m = 20.0
height_m = 10.0
{cell}
[[regions]]
kind = "obstacle"
box = [8.0, 0.0, 12.0, {wall_top}]
[[regions]]
kind = "{gate_kind}"
name = "gate"
box = [0.0, 0.0, 2.0, 10.0]
accessible = ["{first}"]
[[regions]]
kind = "sink"
name = "door"
box = [18.0, 0.0, 20.0, 10.0]
[[waypoints]]
name = "gap"
x_m = {wx}
y_m = 8.0
radius_m = 1.0
accessible = ["door"]
"""
OK = {"cell": "", "wall_top": "6.0", "gate_kind": "generator", "first": "gap", "wx": "10.0"}


def _write(tmp_path, **changes) -> str:
    path = tmp_path / "map.toml"
    path.write_text(GOOD.format(**{**OK, **changes}))
    return str(path)


def test_the_good_map_builds(tmp_path):
    terrain = load_map(_write(tmp_path))
    assert terrain.shape == (10, 20) and terrain.node_names == ("gap", "door", "gate")


@pytest.mark.parametrize("changes, fragments", [
    ({"gate_kind": "free"}, ("regions[1]", "only generators and sinks take a name")),
    ({"gate_kind": "lava"}, ("invalid terrain map", "regions.1.kind", "'obstacle'")),
    ({"wall_top": "10.0", "wx": "5.0"}, ("regions[1] (generator 'gate')", "no path through passable cells")),
    ({"wx": "10.0", "wall_top": "9.0"}, ("waypoints[0] 'gap' at (10, 8) m lies inside an obstacle",
                                         "grid row 8, column 10")),
    ({"first": "nowhere"}, ("regions[1] (generator 'gate')", "accessible names 'nowhere'")),
    ({"wx": "25.0"}, ("waypoints[0] 'gap' at (25, 8) m lies off the map",)),
    ({"cell": "cell_m = 3.0"}, ("20 x 10 m is not a whole number of square cells of cell_m = 3 m",)),
])
def test_bad_maps_are_named(tmp_path, changes, fragments):
    path = _write(tmp_path, **changes)
    with pytest.raises(ConfigError) as err:
        load_map(path)
    for f in (path, *fragments):
        assert f in str(err.value)


def test_a_map_without_generator_or_sink(tmp_path):
    path = tmp_path / "bare.toml"
    path.write_text('name = "bare"\nwidth_m = 10.0\nheight_m = 10.0\n'
                    '[[regions]]\nkind = "sink"\nname = "door"\nbox = [8.0, 0.0, 10.0, 10.0]\n')
    with pytest.raises(ConfigError, match=r"bare.toml: map 'bare': the map has no generator region"):
        load_map(path)
    path.write_text('name = "bare"\nwidth_m = 10.0\nheight_m = 10.0\n'
                    '[[regions]]\nkind = "generator"\nname = "g"\nbox = [0.0, 0.0, 2.0, 10.0]\naccessible = ["g"]\n')
    with pytest.raises(ConfigError, match=r"bare.toml: map 'bare': the map has no sink region"):
        load_map(path)


def test_links_that_never_reach_a_sink(tmp_path):
    path = tmp_path / "loop.toml"
    path.write_text(GOOD.format(**OK).replace('accessible = ["door"]', 'accessible = ["gap"]'))
    with pytest.raises(ConfigError, match=r"loop.toml: .*regions\[1\] \(generator 'gate'\): following `accessible` "
                                          r"from it never leads to a sink"):
        load_map(path)


def test_a_box_outside_the_map_and_an_unreadable_file(tmp_path):
    path = _write(tmp_path, wall_top="12.0")
    with pytest.raises(ConfigError, match=r"regions\[0\] \(obstacle\): box \[8.0, 0.0, 12.0, 12.0\] leaves the map"):
        load_map(path)
    with pytest.raises(ConfigError, match="no such terrain map file"):
        load_map(tmp_path / "missing.toml")


SCENE = 'name = "mine"\nmap = "map.toml"\nduration_s = 20.0\ninitial = 3\n'


def _refused_listing(nnda, root, *args, fragments):
    """A refusal listing its problems (a validation error may take a line per problem): exit 2, nothing
    written, no traceback, every fragment."""
    before = snapshot(root)
    done = nnda(*args, cwd=root)
    assert done.code == 2 and done.err.startswith("error: ") and "Traceback" not in done.err
    assert all(f in done.err for f in fragments), done.err
    assert snapshot(root) == before


def test_nnda_generate_refuses_an_unknown_region_kind(tmp_path, nnda):
    _write(tmp_path, gate_kind="lava")
    (tmp_path / "scene.toml").write_text(SCENE)
    _refused_listing(nnda, tmp_path, "generate", "--config", "scene.toml", "--out", "d",
                     fragments=("map.toml: invalid terrain map", "regions.1.kind", "'generator' or 'sink'"))


@pytest.mark.parametrize("changes, fragments", [
    ({"wx": "10.0", "wall_top": "9.0"}, ("map.toml: map 'tiny': waypoints[0] 'gap'", "inside an obstacle")),
    ({"wall_top": "10.0", "wx": "5.0"}, ("map.toml: map 'tiny': regions[1] (generator 'gate')", "no path")),
])
def test_nnda_generate_refuses_a_walker_scene_on_a_bad_map(tmp_path, refused, changes, fragments):
    _write(tmp_path, **changes)
    (tmp_path / "scene.toml").write_text(SCENE)
    refused(tmp_path, "generate", "--config", "scene.toml", "--out", "d", fragments=fragments)


def test_nnda_generate_refuses_a_bad_walker_scene(tmp_path, refused, nnda):
    _write(tmp_path)
    (tmp_path / "scene.toml").write_text(SCENE.replace("initial = 3", "initial = 0"))
    _refused_listing(nnda, tmp_path, "generate", "--config", "scene.toml", "--out", "d",
                     fragments=("scene.toml: invalid walker scene", "no walker is ever born"))
    (tmp_path / "scene.toml").write_text(SCENE.replace("map.toml", "nowhere.toml"))
    refused(tmp_path, "generate", "--config", "scene.toml", "--out", "d",
            fragments=("nowhere.toml: no such terrain map file",))


def test_nnda_generate_takes_a_walker_scene_file(tmp_path, nnda):
    _write(tmp_path)
    (tmp_path / "scene.toml").write_text(SCENE)
    assert nnda("generate", "--config", "scene.toml", "--out", "d", cwd=tmp_path).code == 0
    assert (tmp_path / "d" / "truth.parquet").is_file()
