from django.urls import path

from dashboard.consumers_teleop import TeleopConsumer

TELEOP_SOCKET_PATH = "/ws/teleop/"

websocket_urlpatterns = [
    path(TELEOP_SOCKET_PATH.lstrip("/"), TeleopConsumer.as_asgi()),
]
