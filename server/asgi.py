import os

os.environ.setdefault("DJANGO_SETTINGS_MODULE", "cyborg_site.settings")

from server.handler import get_asgi_application

django_asgi_app = get_asgi_application()

from channels.auth import AuthMiddlewareStack  # noqa: E402
from channels.routing import ProtocolTypeRouter, URLRouter  # noqa: E402

from cyborg_site.client_address import ClientAddress  # noqa: E402
from cyborg_site.drain import CountRequests, install_in_daphne  # noqa: E402
from dashboard.routing import FRONTDOOR_SOCKET_PATH, websocket_urlpatterns  # noqa: E402
from robot.link.hosting import autostart_in_daphne  # noqa: E402
from robot.teleop.session import halt_all  # noqa: E402
from server import patches as server_patches  # noqa: E402
from server.gc_policy import freeze_when_running_in_daphne  # noqa: E402
from server.read_throttle import ReadThrottle  # noqa: E402
from server.ws_origin import OriginCheck  # noqa: E402

application = ProtocolTypeRouter(
    {
        "http": ClientAddress(CountRequests(ReadThrottle(django_asgi_app))),
        "websocket": ClientAddress(OriginCheck(AuthMiddlewareStack(URLRouter(websocket_urlpatterns)),
                                               ticket_paths=(FRONTDOOR_SOCKET_PATH,))),
    }
)

server_patches.install()  # for the releases they were made for only
autostart_in_daphne(halt_drivers=halt_all)
freeze_when_running_in_daphne()
install_in_daphne()  # SIGTERM: stop listening, finish the requests in flight, then stop
