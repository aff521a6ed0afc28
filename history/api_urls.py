from django.urls import path

from history import api

urlpatterns = [
    path("topics/", api.topics_view, name="history-topics"),
    path("topics/discover/", api.discover_view, name="history-discover"),
    path("recorded/", api.recorded_view, name="history-recorded"),
    path("samples/", api.samples_view, name="history-samples"),
    path("export/", api.ExportView.as_view(), name="history-export"),
    path("timeline/", api.timeline_view, name="history-timeline"),
    path("messages/", api.messages_view, name="history-messages"),
]
