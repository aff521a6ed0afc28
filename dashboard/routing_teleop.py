from django.urls import path

from dashboard.consumers_teleop import TeleopConsumer

websocket_urlpatterns = [
    path("ws/teleop/", TeleopConsumer.as_asgi()),
]
