from django.urls import path

from dashboard.consumers import LiveConsumer
from dashboard.consumers_audio import AudioConsumer
from dashboard.consumers_frontdoor import FrontDoorConsumer
from dashboard.consumers_teleop import TeleopConsumer
from robot.frontdoor import SOCKET_PATH

LIVE_SOCKET_PATH = "/ws/live/"
TELEOP_SOCKET_PATH = "/ws/teleop/"
AUDIO_SOCKET_PATH = "/ws/audio/"
FRONTDOOR_SOCKET_PATH = SOCKET_PATH  # other ROS tools (rosbridge v2), by ticket

websocket_urlpatterns = [
    path(LIVE_SOCKET_PATH.lstrip("/"), LiveConsumer.as_asgi()),
    path(TELEOP_SOCKET_PATH.lstrip("/"), TeleopConsumer.as_asgi()),
    path(AUDIO_SOCKET_PATH.lstrip("/"), AudioConsumer.as_asgi()),
    path(FRONTDOOR_SOCKET_PATH.lstrip("/"), FrontDoorConsumer.as_asgi()),
]
