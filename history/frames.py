"""Recorded camera frames: JPEG files under ``CAMERA_RECORD_DIR``, indexed by rows in the database.

Why files: at the default 2 frames per second a day of camera is a few gigabytes of JPEG that
never changes once written. In the database it would swell the write-ahead log, backups and
vacuum of the table every seek reads, for no query that needs it; as files it is written
once, read straight from disk and deleted by name. The row (time, path, size) keeps seeking
one indexed query and makes retention and incidents plain database work. The file is
written (and renamed into place) before its row, so a row always has its file; half-written
files (``.part``, a crash mid-write) are swept with their hour by ``prune_frames``.
"""

from __future__ import annotations

import logging
import os
import time
from collections.abc import Sequence
from contextlib import suppress
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from django.conf import settings
from django.db import transaction
from django.db.models import Q

from history.models import CameraFrame, Incident

log = logging.getLogger(__name__)

# (receive time, JPEG bytes, incident id or None)
Frame = tuple[float, bytes, int | None]
# A frame further than this from the asked time is not "the frame of that moment".
NEAREST_S = 5.0


def frame_dir() -> Path:
    return Path(settings.CAMERA_RECORD_DIR)


def relative_path(t: float) -> str:
    """One folder per hour, one file per frame named by its millisecond."""
    moment = datetime.fromtimestamp(t, tz=UTC)
    return f"{moment:%Y-%m-%d/%H}/{round(t * 1000)}.jpg"


def write_frames(frames: Sequence[Frame]) -> int:
    """Store frames (files, then their rows); returns how many."""
    if not frames:
        return 0
    root = frame_dir()
    rows = []
    for t, jpeg, incident in frames:
        rel = relative_path(t)
        path = root / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        partial = path.with_suffix(".part")
        partial.write_bytes(jpeg)
        os.replace(partial, path)
        rows.append(CameraFrame(t=t, path=rel, size=len(jpeg), incident_id=incident))
    CameraFrame.objects.bulk_create(rows)
    return len(rows)


def frame_at(t: float) -> CameraFrame | None:
    """The newest frame at or before ``t`` (within ``NEAREST_S``)."""
    return CameraFrame.objects.filter(t__lte=t, t__gte=t - NEAREST_S).order_by("-t").first()


def frame_file(frame: CameraFrame) -> Path:
    return frame_dir() / frame.path


def held_windows() -> list[tuple[float, float]]:
    return list(Incident.objects.filter(held=True).values_list("start", "end"))


def outside(windows: Sequence[tuple[Any, Any]], field: str) -> Q:
    """A filter that leaves out rows whose ``field`` falls in any of the windows."""
    keep = Q()
    for start, end in windows:
        keep |= Q(**{f"{field}__gte": start, f"{field}__lte": end})
    return ~keep if windows else Q()


def prune_frames(*, now: float | None = None, retention_s: float | None = None) -> int:
    """Delete frames older than the camera's retention, except inside held incidents; returns how many."""
    now = now or time.time()
    cutoff = now - (retention_s or settings.CAMERA_RETENTION_S)
    expired = CameraFrame.objects.filter(t__lt=cutoff).filter(outside(held_windows(), "t"))
    deleted = 0
    while batch := list(expired.values_list("id", "path")[:2000]):
        for _, rel in batch:
            (frame_dir() / rel).unlink(missing_ok=True)
        with transaction.atomic():
            deleted += CameraFrame.objects.filter(id__in=[i for i, _ in batch]).delete()[0]
    _remove_empty_hours(cutoff)
    return deleted


def _remove_empty_hours(cutoff: float) -> None:
    root = frame_dir()
    if not root.is_dir():
        return
    for day in root.iterdir():
        for hour in (day.iterdir() if day.is_dir() else ()):
            if hour.is_dir() and hour.stat().st_mtime < cutoff:
                for stray in hour.glob("*.part"):
                    stray.unlink(missing_ok=True)
                with suppress(OSError):
                    hour.rmdir()  # only when empty
        with suppress(OSError):
            day.rmdir()
