"""Named locations seeded from what the robot reports: its navigation node names the place it is at
("reception") from its own database, which the server cannot read. A name the server does not know
yet becomes a named location at the pose the robot reported while there, so the list does not start
empty; an admin may move or delete it like any other (a deleted one comes back only when the robot
reports it again after the link restarts)."""

from __future__ import annotations

import logging
from typing import Any

from django.core.exceptions import ValidationError

from robot.navigation.transforms import quaternion_to_yaw

log = logging.getLogger(__name__)

DESCRIPTION = "Named by the robot; placed where it reported being there"


def location_seed(*, name: str, pose: dict[str, Any]) -> bool:
    """Create the named location ``name`` at ``pose`` (geometry_msgs/Pose) unless one exists; True if made."""
    from robot.models import Location

    if Location.objects.filter(name=name).exists():
        return False
    location = Location(name=name, x=float(pose["position"]["x"]), y=float(pose["position"]["y"]),
                        yaw=quaternion_to_yaw(pose.get("orientation") or {}), description=DESCRIPTION)
    try:
        location.full_clean()
    except ValidationError:
        log.warning("the robot is at %r, a name that cannot be a named location here; not added", name)
        return False
    location.save()
    log.info("named location %r added where the robot reports being there (%.2f, %.2f)", name, location.x, location.y)
    return True
