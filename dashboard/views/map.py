from pathlib import Path

from django.conf import settings
from django.http import FileResponse, Http404, HttpRequest, HttpResponse, HttpResponseBase, HttpResponseNotModified
from django.shortcuts import render
from django.urls import reverse
from django.views.decorators.http import require_GET

from dashboard.preferences import map_overlays
from robot import interface as ri
from robot.live.keys import MAP_PAGE_KEYS
from robot.navigation.mapimage import is_version, map_dir, png_path
from robot.navigation.selectors import location_list, map_meta
from robot.navigation.status import FOREIGN_GOAL_BY, GOAL_ID_PREFIX
from robot.overlays.costmap import LAYERS, costmap_dir, is_tile_name


def map_page(request: HttpRequest) -> HttpResponse:
    config = {
        "keys": list(MAP_PAGE_KEYS),
        "map": map_meta(),
        "locations": location_list(),
        "overlays": map_overlays(request.user),
        "backend": settings.NAVIGATION_BACKEND,
        "stale_after_s": settings.STALE_AFTER_S,
        "goal_status": ri.GOAL_STATUS,
        "goal_id_prefix": GOAL_ID_PREFIX,
        "foreign_goal_by": FOREIGN_GOAL_BY,
        "urls": {
            "map": reverse("api-map"),
            "overlays": reverse("api-map-overlays"),
            "goal": reverse("api-navigation-goal"),
            "cancel": reverse("api-navigation-cancel"),
            "status": reverse("api-navigation-status"),
            "initial_pose": reverse("api-navigation-initial-pose"),
            "locations": reverse("api-location-list"),
            # {name} is replaced by the location's name.
            "location": reverse("api-location-detail", args=["NAME"]).replace("NAME", "{name}"),
            "location_go": reverse("api-location-go", args=["NAME"]).replace("NAME", "{name}"),
        },
    }
    return render(request, "dashboard/map.html", {"map_config": config})


@require_GET
def map_image(request: HttpRequest, version: str) -> HttpResponseBase:
    """A rendered map version: immutable, so browsers cache it for good and revalidate never."""
    if not is_version(version):
        raise Http404("no such map version")
    return _immutable_png(request, png_path(map_dir(), version), f'"{version}"')


def _immutable_png(request: HttpRequest, path: Path, etag: str) -> HttpResponseBase:
    response: HttpResponseBase
    if request.headers.get("If-None-Match") == etag and path.exists():
        response = HttpResponseNotModified()
    else:
        try:
            response = FileResponse(open(path, "rb"), content_type="image/png")
        except FileNotFoundError:
            raise Http404("no such image") from None
    response["ETag"] = etag
    response["Cache-Control"] = "public, max-age=31536000, immutable"
    return response


@require_GET
def costmap_tile(request: HttpRequest, layer: str, version: str, name: str) -> HttpResponseBase:
    """One tile revision of a rendered costmap: immutable like the map image."""
    if layer not in LAYERS or not is_version(version) or not is_tile_name(name):
        raise Http404("no such costmap tile")
    return _immutable_png(request, costmap_dir() / layer / version / f"{name}.png", f'"{version}-{name}"')
