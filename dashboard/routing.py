from django.urls import path

from dashboard.consumers import LiveConsumer
from dashboard.consumers_audio import AudioConsumer
from dashboard.routing_teleop import websocket_urlpatterns as teleop_patterns

LIVE_SOCKET_PATH = "/ws/live/"
AUDIO_SOCKET_PATH = "/ws/audio/"

websocket_urlpatterns = [
    path(LIVE_SOCKET_PATH.lstrip("/"), LiveConsumer.as_asgi()),
    path(AUDIO_SOCKET_PATH.lstrip("/"), AudioConsumer.as_asgi()),
    *teleop_patterns,
]
