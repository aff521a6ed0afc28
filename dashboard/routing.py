from django.urls import path

from dashboard.consumers import LiveConsumer
from dashboard.routing_teleop import websocket_urlpatterns as teleop_patterns

LIVE_SOCKET_PATH = "/ws/live/"

websocket_urlpatterns = [
    path(LIVE_SOCKET_PATH.lstrip("/"), LiveConsumer.as_asgi()),
    *teleop_patterns,
]
