from django.urls import path

from dashboard.views.activity import activity
from dashboard.views.drive import drive
from dashboard.views.health import healthz
from dashboard.views.home import home
from dashboard.views.map import map_image, map_page
from dashboard.views.video import video_snapshot, video_stream

app_name = "dashboard"

urlpatterns = [
    path("", home, name="home"),
    path("healthz", healthz, name="healthz"),
    path("activity/", activity, name="activity"),
    path("map/", map_page, name="map"),
    path("map/image/<str:version>.png", map_image, name="map-image"),
    path("drive/", drive, name="drive"),
    path("video/stream", video_stream, name="video-stream"),
    path("video/snapshot", video_snapshot, name="video-snapshot"),
]
