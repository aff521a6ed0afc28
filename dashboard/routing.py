from django.urls import path

from dashboard.consumers import LiveConsumer
from dashboard.consumers_audio import AudioConsumer
from dashboard.consumers_teleop import TeleopConsumer

LIVE_SOCKET_PATH = "/ws/live/"
TELEOP_SOCKET_PATH = "/ws/teleop/"
AUDIO_SOCKET_PATH = "/ws/audio/"

websocket_urlpatterns = [
    path(LIVE_SOCKET_PATH.lstrip("/"), LiveConsumer.as_asgi()),
    path(TELEOP_SOCKET_PATH.lstrip("/"), TeleopConsumer.as_asgi()),
    path(AUDIO_SOCKET_PATH.lstrip("/"), AudioConsumer.as_asgi()),
]
