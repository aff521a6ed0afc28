from django.urls import path

from dashboard.views.drive import drive
from dashboard.views.video import video_snapshot, video_stream

urlpatterns = [
    path("drive/", drive, name="drive"),
    path("video/stream", video_stream, name="video-stream"),
    path("video/snapshot", video_snapshot, name="video-snapshot"),
]
