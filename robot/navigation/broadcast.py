"""Tell every open map page when the named locations change (API, admin or shell).

The list is only sent, never stored as latest state: a page gets the current list with the
page itself (and again whenever its socket reconnects), so a stored copy could only ever be
older than what the page already has.
"""

from __future__ import annotations

from typing import Any

from asgiref.sync import async_to_sync
from django.db import transaction
from django.db.models.signals import post_delete, post_save

from robot.live.announce import apublish_state
from robot.live.groups import LOCATIONS_KEY
from robot.models import Location
from robot.navigation.selectors import location_list


def broadcast_locations() -> None:
    async_to_sync(apublish_state)(LOCATIONS_KEY, {"locations": location_list()}, keep=False)


def _changed(sender: type[Location], **kwargs: Any) -> None:
    transaction.on_commit(broadcast_locations)  # after the change is visible to everyone


def connect() -> None:
    post_save.connect(_changed, sender=Location, dispatch_uid="robot.navigation.locations-changed")
    post_delete.connect(_changed, sender=Location, dispatch_uid="robot.navigation.locations-deleted")
