import os
from functools import partialmethod

from django.core.asgi import get_asgi_application

os.environ.setdefault("DJANGO_SETTINGS_MODULE", "cyborg_site.settings")
django_asgi_app = get_asgi_application()

from channels.auth import AuthMiddlewareStack  # noqa: E402
from channels.routing import ProtocolTypeRouter, URLRouter  # noqa: E402
from daphne.http_protocol import WebRequest  # noqa: E402
from daphne.ws_protocol import WebSocketProtocol  # noqa: E402

from cyborg_site.ws_origin import OriginCheck  # noqa: E402
from dashboard.routing import websocket_urlpatterns  # noqa: E402
from robot.link.hosting import autostart_in_daphne  # noqa: E402

application = ProtocolTypeRouter(
    {
        "http": django_asgi_app,
        "websocket": OriginCheck(AuthMiddlewareStack(URLRouter(websocket_urlpatterns))),
    }
)

# Same autobahn ordering issue as the robot link (robot/link/connection.py): without a class default,
# browsers' websockets keep Nagle on and small frames stall on delayed ACKs.
WebSocketProtocol.tcpNoDelay = True
# Twisted parses POSTed form bodies itself (Daphne never reads the result) and answers a body it
# cannot parse with a bare, empty 400 before Django sees it; let Django give its usual error.
WebRequest.__init__ = partialmethod(WebRequest.__init__, parsePOSTFormSubmission=False)

autostart_in_daphne()
