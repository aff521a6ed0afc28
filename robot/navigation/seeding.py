"""Named locations seeded from what the robot reports: its navigation node names the place it is at
("reception") from its own database, which the server cannot read. A name the server does not know
yet becomes a named location at the pose the robot reported while there, so the list does not start
empty; an admin may move or delete it like any other (a deleted one comes back only when the robot
reports it again after the link restarts)."""

from __future__ import annotations

import logging
import math
from typing import Any

from django.core.exceptions import ValidationError

log = logging.getLogger(__name__)

DESCRIPTION = "Named by the robot; placed where it reported being there"


def _yaw(orientation: dict[str, Any]) -> float:
    x, y, z, w = (float(orientation.get(k, 0.0)) for k in ("x", "y", "z", "w"))
    return math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


def location_seed(*, name: str, pose: dict[str, Any]) -> bool:
    """Create the named location ``name`` at ``pose`` (geometry_msgs/Pose) unless one exists; True if made."""
    from robot.models import Location

    if Location.objects.filter(name=name).exists():
        return False
    location = Location(name=name, x=float(pose["position"]["x"]), y=float(pose["position"]["y"]),
                        yaw=_yaw(pose.get("orientation") or {}), description=DESCRIPTION)
    try:
        location.full_clean()
    except ValidationError:
        log.warning("the robot is at %r, a name that cannot be a named location here; not added", name)
        return False
    location.save()
    log.info("named location %r added where the robot reports being there (%.2f, %.2f)", name, location.x, location.y)
    return True
