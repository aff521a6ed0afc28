"""Render an OccupancyGrid to a PNG once per map version, cached on disk.

The PNG is a palette image whose pixel index is the cell value itself (int8 viewed as
uint8, so unknown -1 is 255): rendering is a flip and a PNG encode, no per-cell work in
Python. Beside it a ``.npy`` copy of the grid lets any process (web or link) check cells
for goal validation with a memory map instead of decoding the image.
"""

from __future__ import annotations

import hashlib
import io
import os
import time
from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np
from django.conf import settings
from PIL import Image

from robot.navigation.transforms import MapGeometry

UNKNOWN = -1
OCCUPIED_AT = 50  # values at or above this are obstacles (map_server's occupied_thresh 0.65 is stricter)
KEEP_VERSIONS = 4
_VERSION_CHARS = frozenset("0123456789abcdef")

UNKNOWN_RGB = (205, 210, 217)
FREE_RGB = (252, 252, 250)
OCCUPIED_RGB = (34, 38, 46)


def map_dir() -> Path:
    """Where rendered maps live (shared by every process of one deployment)."""
    return Path(settings.VAR_DIR) / "maps"


def _palette() -> list[int]:
    table: list[tuple[int, ...]] = [UNKNOWN_RGB] * 256
    for v in range(101):  # free .. occupied, shaded by probability
        f = v / 100.0
        table[v] = tuple(round(a + (b - a) * f) for a, b in zip(FREE_RGB, OCCUPIED_RGB, strict=True))
    return [channel for rgb in table for channel in rgb]


PALETTE = _palette()


class MapError(ValueError):
    pass


@dataclass(frozen=True)
class RenderedMap:
    version: str
    geometry: MapGeometry
    png: Path
    cached: bool  # the image already existed (same map seen before)
    convert_ms: float
    render_ms: float


def grid_array(msg: dict[str, Any]) -> tuple[MapGeometry, np.ndarray]:
    """The grid as an int8 array of shape (height, width), row 0 at the map origin."""
    geometry = MapGeometry.from_info(msg["info"])
    data = msg.get("data")
    if data is None:
        data = []
    n = geometry.width * geometry.height
    if n <= 0 or len(data) != n or geometry.resolution <= 0:
        raise MapError(f"map of {geometry.width}x{geometry.height} cells came with {len(data)} values")
    # A large map's data is already an ndarray (robot.link.wire); a small one is a list.
    try:
        values = data if isinstance(data, np.ndarray) else np.array(data, dtype=np.int32)
    except (OverflowError, TypeError, ValueError) as exc:
        raise MapError(f"map cells must be integers: {exc}") from None
    if values.min() < UNKNOWN or values.max() > 100:
        raise MapError(f"map cells must be {UNKNOWN}..100, not {values.min()}..{values.max()}")
    return geometry, values.astype(np.int8).reshape(geometry.height, geometry.width)


def map_version(geometry: MapGeometry, grid: np.ndarray) -> str:
    h = hashlib.blake2b(repr(geometry).encode(), digest_size=10)
    h.update(grid.tobytes())
    return h.hexdigest()


def is_version(text: str) -> bool:
    return len(text) == 20 and set(text) <= _VERSION_CHARS


def png_path(directory: Path, version: str) -> Path:
    return directory / f"{version}.png"


def grid_path(directory: Path, version: str) -> Path:
    return directory / f"{version}.npy"


def palette_png(cells: np.ndarray, palette: list[int], **options: Any) -> bytes:
    """Cells (rows top-down, values -1..100) as a palette PNG whose pixel index is the cell value."""
    pixels = np.ascontiguousarray(cells).view(np.uint8)
    image = Image.frombuffer("P", (cells.shape[1], cells.shape[0]), pixels, "raw", "P", 0, 1)
    image.putpalette(palette)
    out = io.BytesIO()
    image.save(out, "PNG", **options)
    return out.getvalue()


def write_atomically(path: Path, write: Callable[[BinaryIO], object]) -> None:
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    with open(tmp, "wb") as f:
        write(f)
    os.replace(tmp, path)  # readers never see half a file, even with several writers


def render_map(msg: dict[str, Any], directory: Path) -> RenderedMap:
    """Convert, version and (unless this version is on disk already) render ``msg``. Blocking."""
    t0 = time.perf_counter()
    geometry, grid = grid_array(msg)
    version = map_version(geometry, grid)
    t1 = time.perf_counter()
    png = png_path(directory, version)
    cached = png.exists() and grid_path(directory, version).exists()
    if not cached:
        directory.mkdir(parents=True, exist_ok=True)
        write_atomically(grid_path(directory, version), lambda f: np.save(f, grid, allow_pickle=False))
        data = palette_png(np.flipud(grid), PALETTE, compress_level=3)
        write_atomically(png, lambda f: f.write(data))
        _prune(directory, keep=version)
    t2 = time.perf_counter()
    return RenderedMap(version, geometry, png, cached, (t1 - t0) * 1000, (t2 - t1) * 1000)


def _prune(directory: Path, *, keep: str) -> None:
    pngs = sorted(directory.glob("*.png"), key=lambda p: p.stat().st_mtime, reverse=True)
    for old in pngs[KEEP_VERSIONS:]:
        if old.stem != keep:
            for path in (old, grid_path(directory, old.stem)):
                path.unlink(missing_ok=True)


@lru_cache(maxsize=4)
def _grid(path: Path) -> np.ndarray:
    return np.load(path, mmap_mode="r", allow_pickle=False)


def cell_value(directory: Path, version: str, row: int, col: int) -> int | None:
    """The value of one cell of a rendered map version; None when that version is not on disk."""
    path = grid_path(directory, version)
    if not path.exists():
        return None
    return int(_grid(path)[row, col])
