"""Costmaps render once per version to tiles; an update re-renders only the tiles it touches."""

import io

import numpy as np
import pytest
from PIL import Image

from robot.overlays.costmap import TILE, Costmap, UpdateError, costmap_dir


def grid_msg(width, height, data, x=0.0, y=0.0):
    return {"header": {"frame_id": "map"}, "info": {
        "resolution": 0.05, "width": width, "height": height,
        "origin": {"position": {"x": x, "y": y, "z": 0.0}, "orientation": {"x": 0, "y": 0, "z": 0, "w": 1}}},
        "data": data}


def tile_pixels(costmap, row, col):
    return np.array(Image.open(io.BytesIO(costmap.tile_path(row, col).read_bytes())))


def test_it_renders_every_tile_with_row_zero_at_the_bottom():
    w, h = TILE + 10, 20
    cells = np.zeros((h, w), np.int8)
    cells[0, 0] = 100  # the grid's first cell: bottom-left of the image
    cells[h - 1, w - 1] = 99
    costmap = Costmap("global", costmap_dir())
    costmap.load(grid_msg(w, h, cells.ravel().tolist()), "map")
    assert costmap.revisions.shape == (1, 2)
    left, right = tile_pixels(costmap, 0, 0), tile_pixels(costmap, 0, 1)
    assert left.shape == (h, TILE) and right.shape == (h, 10)
    assert left[h - 1, 0] == 100 and right[0, 9] == 99
    assert left.sum() == 100 and right.sum() == 99
    image = Image.open(costmap.tile_path(0, 0))
    alpha = image.info["transparency"]
    assert alpha[0] == 0 and alpha[100] > 150  # free cells clear, lethal ones strong


def test_an_update_patches_the_cells_and_re_renders_only_its_tiles():
    w, h = 2 * TILE, 2 * TILE
    costmap = Costmap("global", costmap_dir())
    costmap.load(grid_msg(w, h, np.zeros(w * h, np.int8)), "map")
    before = {p.name for p in costmap.folder.iterdir()}
    assert len(before) == 4
    # 3 x 2 cells near the top-right corner of the bottom-left tile
    costmap.patch({"x": TILE - 3, "y": TILE - 2, "width": 3, "height": 2, "data": [50, 51, 52, 60, 61, 62]})
    assert costmap.revisions.tolist() == [[0, 0], [1, 0]]  # tile rows run top-down: the bottom row is row 1
    tile = tile_pixels(costmap, 1, 0)
    assert tile[0, TILE - 3:].tolist() == [60, 61, 62]  # the update's second row is higher up the map
    assert tile[1, TILE - 3:].tolist() == [50, 51, 52]
    assert tile.sum() == sum([50, 51, 52, 60, 61, 62])
    # both revisions of the patched tile are on disk while a page may still load the old one
    costmap.patch({"x": 0, "y": 0, "width": 1, "height": 1, "data": [100]})
    names = {p.name for p in costmap.folder.iterdir()}
    assert "1-0-2.png" in names and "1-0-1.png" in names and "1-0-0.png" not in names


@pytest.mark.parametrize("update, message", [
    ({"x": 0, "y": 0, "width": 3, "height": 3, "data": [0] * 9}, "outside"),
    ({"x": 0, "y": 0, "width": 2, "height": 2, "data": [0] * 3}, "with 3 values"),
    ({"x": 0, "y": 0, "width": 1, "height": 1, "data": [101]}, "-1..100"),
    ({"x": "a", "y": 0, "width": 1, "height": 1, "data": [0]}, "integer"),
])
def test_it_refuses_updates_that_do_not_fit(update, message):
    costmap = Costmap("local", costmap_dir())
    with pytest.raises(UpdateError, match="before"):
        costmap.patch(update)
    costmap.load(grid_msg(2, 2, [0, 0, 0, 0]), "odom")
    with pytest.raises(UpdateError, match=message):
        costmap.patch(update)


def test_a_new_version_replaces_old_folders_but_keeps_the_previous_one():
    costmap = Costmap("local", costmap_dir())
    versions = []
    for k in range(4):
        costmap.load(grid_msg(4, 4, [k] * 16, x=float(k)), "odom")
        versions.append(costmap.version)
    folders = {p.name for p in (costmap_dir() / "local").iterdir()}
    assert folders == set(versions[-2:])
