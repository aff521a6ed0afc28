"""The history page (namespaced ``history:``) and its API (``api_urlpatterns``, under /api/history/)."""

from django.urls import path

from history import api, views

app_name = "history"
urlpatterns = [
    path("", views.index, name="index"),
]

api_urlpatterns = [
    path("topics/", api.topics_view, name="history-topics"),
    path("topics/discover/", api.discover_view, name="history-discover"),
    path("recorded/", api.recorded_view, name="history-recorded"),
    path("samples/", api.samples_view, name="history-samples"),
    path("export/", api.ExportView.as_view(), name="history-export"),
    path("timeline/", api.timeline_view, name="history-timeline"),
    path("messages/", api.messages_view, name="history-messages"),
]
