import os
from functools import partialmethod

os.environ.setdefault("DJANGO_SETTINGS_MODULE", "cyborg_site.settings")

from cyborg_site.handler import get_asgi_application

django_asgi_app = get_asgi_application()

from channels.auth import AuthMiddlewareStack  # noqa: E402
from channels.routing import ProtocolTypeRouter, URLRouter  # noqa: E402
from daphne.http_protocol import HTTPFactory, WebRequest  # noqa: E402
from daphne.ws_protocol import WebSocketProtocol  # noqa: E402

from cyborg_site import direct_frames, reaping, refused_handshakes  # noqa: E402
from cyborg_site.client_address import ClientAddress  # noqa: E402
from cyborg_site.drain import CountRequests, install_in_daphne  # noqa: E402
from cyborg_site.gc_policy import freeze_when_running_in_daphne  # noqa: E402
from cyborg_site.read_throttle import ReadThrottle  # noqa: E402
from cyborg_site.server_versions import refuse_other_releases  # noqa: E402
from cyborg_site.ws_origin import OriginCheck  # noqa: E402
from dashboard.routing import websocket_urlpatterns  # noqa: E402
from robot.api.fast_commands import FastCommandApp  # noqa: E402
from robot.api.fast_state import FastStateApp  # noqa: E402
from robot.link.hosting import autostart_in_daphne  # noqa: E402

application = ProtocolTypeRouter(
    {
        "http": ClientAddress(CountRequests(ReadThrottle(FastCommandApp(FastStateApp(django_asgi_app),
                                                                        django_asgi_app)))),
        "websocket": ClientAddress(OriginCheck(AuthMiddlewareStack(URLRouter(websocket_urlpatterns)))),
    }
)

# Server internals are patched below, for the releases they were made for only.
refuse_other_releases()
# Same autobahn ordering issue as the robot link (robot/link/connection.py): without a class default,
# browsers' websockets keep Nagle on and small frames stall on delayed ACKs.
WebSocketProtocol.tcpNoDelay = True
# The live hub writes pre-encoded frames straight to each connection (see the module).
direct_frames.install()
# Daphne forgets a finished request at once, not at its next once-a-second sweep (see the module).
reaping.install()
# A malformed Host or Origin is refused by autobahn with one warning line, not a CRITICAL traceback.
refused_handshakes.install()
# Twisted parses POSTed form bodies itself (Daphne never reads the result) and answers a body it
# cannot parse with a bare, empty 400 before Django sees it; let Django give its usual error.
WebRequest.__init__ = partialmethod(WebRequest.__init__, parsePOSTFormSubmission=False)
# Daphne writes its own access log line per request and sends Twisted's log nowhere, but the embedded
# link's roslibpy routes Twisted's log to Python logging again: each request was logged a second time
# in Twisted's format, through three loggers (an eighth of the state API's CPU). Daphne's line stays.
HTTPFactory.log = lambda self, request: None

autostart_in_daphne()
freeze_when_running_in_daphne()
install_in_daphne()  # SIGTERM: stop listening, finish the requests in flight, then stop
