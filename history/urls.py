"""The history page (namespaced ``history:``) and its API (``api_urlpatterns``, under /api/history/)."""

from django.urls import path

from history import api, replay_api, views

app_name = "history"
urlpatterns = [
    path("", views.index, name="index"),
    path("replay/", views.replay_page, name="replay"),
    path("incidents/", views.incidents_page, name="incidents"),
]

api_urlpatterns = [
    path("topics/", api.topics_view, name="history-topics"),
    path("topics/discover/", api.discover_view, name="history-discover"),
    path("recorded/", api.recorded_view, name="history-recorded"),
    path("samples/", api.samples_view, name="history-samples"),
    path("export/", api.ExportView.as_view(), name="history-export"),
    path("timeline/", api.timeline_view, name="history-timeline"),
    path("messages/", api.messages_view, name="history-messages"),
    path("replay/state/", replay_api.state_view, name="history-replay-state"),
    path("replay/window/", replay_api.window_view, name="history-replay-window"),
    path("replay/span/", replay_api.span_view, name="history-replay-span"),
    path("replay/map/<int:sample_id>.png", replay_api.map_view, name="history-replay-map"),
    path("frames/<int:frame_id>.jpg", replay_api.frame_view, name="history-frame"),
    path("incidents/", replay_api.incidents_view, name="history-incidents"),
    path("incidents/<int:incident_id>/release/", replay_api.release_view, name="history-incident-release"),
    path("incidents/<int:incident_id>/mcap/", replay_api.mcap_view, name="history-incident-mcap"),
]
