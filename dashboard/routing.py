from django.urls import path

from dashboard.consumers import LiveConsumer
from dashboard.routing_teleop import websocket_urlpatterns as teleop_patterns

websocket_urlpatterns = [
    path("ws/live/", LiveConsumer.as_asgi()),
    *teleop_patterns,
]
