"""Costmaps as translucent image tiles: rendered once per version, partial updates patch tiles.

A costmap can be as large as the map (4000 x 4000 cells, tens of MB as JSON), so a page never
gets its cells: it gets tiles (``TILE`` x ``TILE`` palette PNGs, the pixel index being the cell
value, as for the map) and the costmap's metadata with every tile's revision. A partial update
(``map_msgs/OccupancyGridUpdate``) changes the cells in memory and re-encodes only the tiles it
touches, each under a new revision; a page fetches just those. Tiles are immutable files
(``<version>/<row>-<col>-<revision>.png``), so every web process serves them as they are.
"""

from __future__ import annotations

import re
import shutil
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from django.conf import settings

from robot.navigation.mapimage import MapError, grid_array, map_version, palette_png, write_atomically
from robot.navigation.transforms import MapGeometry

TILE = 512
LAYERS = ("global", "local")
KEEP_VERSIONS = 2  # the current one, and the one a page may still be loading
_TILE_NAME = re.compile(r"^(\d{1,4})-(\d{1,4})-(\d{1,9})$")


def costmap_dir() -> Path:
    return Path(settings.VAR_DIR) / "costmaps"


def is_tile_name(name: str) -> bool:
    return _TILE_NAME.match(name) is not None


def _palette() -> tuple[list[int], bytes]:
    """RGB and alpha per cell value: free and unknown clear, cost from blue to red, inscribed
    and lethal the strongest (colours after RViz's costmap scheme)."""
    rgb: list[tuple[int, int, int]] = [(0, 0, 0)] * 256
    alpha = [0] * 256
    for v in range(1, 99):
        f = (v - 1) / 97.0
        rgb[v] = (round(40 + 215 * f), round(90 * (1 - f)), round(230 * (1 - f)))
        alpha[v] = round(60 + 110 * f)
    rgb[99], alpha[99] = (0, 200, 230), 190  # inscribed: the robot's centre here means a collision
    rgb[100], alpha[100] = (170, 0, 170), 215  # lethal
    return [c for colour in rgb for c in colour], bytes(alpha)


PALETTE, ALPHA = _palette()


class UpdateError(ValueError):
    pass


@dataclass
class Costmap:
    """One costmap layer's cells and tiles, as the robot link keeps them."""

    layer: str
    directory: Path
    version: str = ""
    geometry: MapGeometry | None = None
    frame: str = ""
    image: np.ndarray = field(default_factory=lambda: np.zeros((0, 0), np.int8))  # rows top-down
    revisions: np.ndarray = field(default_factory=lambda: np.zeros((0, 0), np.int64))
    render_ms: float = 0.0

    @property
    def folder(self) -> Path:
        return self.directory / self.layer / self.version

    def tile_path(self, row: int, col: int) -> Path:
        return self.folder / f"{row}-{col}-{int(self.revisions[row, col])}.png"

    def load(self, msg: dict[str, Any], frame: str) -> None:
        """A whole ``nav_msgs/OccupancyGrid``: a new version, every tile rendered. Blocking."""
        t0 = time.perf_counter()
        geometry, grid = grid_array(msg)
        version = map_version(geometry, grid)
        self.geometry, self.frame = geometry, frame
        if version != self.version:
            self.version = version
            self.image = np.ascontiguousarray(np.flipud(grid))
            rows, cols = -(-geometry.height // TILE), -(-geometry.width // TILE)
            self.revisions = np.zeros((rows, cols), np.int64)
            self.folder.mkdir(parents=True, exist_ok=True)
            for r in range(rows):
                for c in range(cols):
                    self._render(r, c)
            self._prune_versions()
        self.render_ms = (time.perf_counter() - t0) * 1000

    def patch(self, update: dict[str, Any]) -> None:
        """A ``map_msgs/OccupancyGridUpdate``: its cells replaced, the tiles it touches re-rendered. Blocking."""
        t0 = time.perf_counter()
        g = self.geometry
        if g is None or not self.version:
            raise UpdateError("an update came before the costmap itself")
        try:
            x, y, w, h = (int(update[k]) for k in ("x", "y", "width", "height"))
        except (KeyError, TypeError, ValueError):
            raise UpdateError("an update needs integer x, y, width and height") from None
        if w <= 0 or h <= 0 or x < 0 or y < 0 or x + w > g.width or y + h > g.height:
            raise UpdateError(f"update {w}x{h} at ({x}, {y}) is outside the {g.width}x{g.height} costmap")
        data = update.get("data")
        values = data if isinstance(data, np.ndarray) else np.array(data if data is not None else [], np.int32)
        if values.size != w * h:
            raise UpdateError(f"update of {w}x{h} cells came with {values.size} values")
        if values.size and (values.min() < -1 or values.max() > 100):
            raise UpdateError("costmap cells must be -1..100")
        top = g.height - (y + h)  # image rows run top-down
        self.image[top:top + h, x:x + w] = np.flipud(values.astype(np.int8).reshape(h, w))
        for r in range(top // TILE, (top + h - 1) // TILE + 1):
            for c in range(x // TILE, (x + w - 1) // TILE + 1):
                old = self.tile_path(r, c)
                self.revisions[r, c] += 1
                self._render(r, c)
                self._forget(old)
        self.render_ms = (time.perf_counter() - t0) * 1000

    def _render(self, row: int, col: int) -> None:
        cells = self.image[row * TILE:(row + 1) * TILE, col * TILE:(col + 1) * TILE]
        data = palette_png(cells, PALETTE, compress_level=1, transparency=ALPHA)  # transparent per value
        write_atomically(self.tile_path(row, col), lambda f: f.write(data))

    def _forget(self, path: Path) -> None:
        # Keep the revision before the one just replaced: a page may still be fetching it.
        m = _TILE_NAME.match(path.stem)
        if m and int(m[3]) > 0:
            (path.parent / f"{m[1]}-{m[2]}-{int(m[3]) - 1}.png").unlink(missing_ok=True)

    def _prune_versions(self) -> None:
        folders = [p for p in (self.directory / self.layer).iterdir() if p.is_dir()]
        folders.sort(key=lambda p: p.stat().st_mtime, reverse=True)
        for old in folders[KEEP_VERSIONS:]:
            if old.name != self.version:
                shutil.rmtree(old, ignore_errors=True)

    def meta(self, in_map: dict[str, float] | None, url: str, received: float) -> dict[str, Any]:
        """What a page needs to draw this layer: its size, where its origin lies on the map (None while
        the transform from its frame is unknown), and each tile's revision."""
        g = self.geometry
        assert g is not None
        return {
            "layer": self.layer, "version": self.version, "width": g.width, "height": g.height,
            "resolution": g.resolution, "frame": self.frame, "origin": in_map, "tile": TILE,
            "tiles": self.revisions.tolist(), "url": url, "received": received, "render_ms": round(self.render_ms, 1),
        }


__all__ = ["LAYERS", "TILE", "Costmap", "MapError", "UpdateError", "costmap_dir", "is_tile_name"]
