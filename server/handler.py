"""Django's ASGI handler, with the middleware chain and the view run in one hop to a thread.

Every view here is synchronous (DRF, the pages) and so is most middleware. Under Django's own
ASGI handler the chain runs "asynchronously": each middleware's ``process_request`` and
``process_response`` crosses to a thread and back, a synchronous-only middleware (WhiteNoise)
crosses the other way for everything inside it, and the view crosses again: about fifteen
crossings per request, each a thread wake-up and a GIL hand-off (up to the 5 ms switch interval
on a busy server). Here the chain is built as for WSGI and the whole request runs in one thread
hop, like a WSGI worker; an async view (the video stream) is run on the loop by Django as under
WSGI. Work that needs the event loop (a command's ``send``) crosses back once, from the view.
"""

from __future__ import annotations

from typing import Any

from asgiref.sync import sync_to_async
from django.core.handlers.asgi import ASGIHandler
from django.http import HttpRequest


class OneHopASGIHandler(ASGIHandler):
    def load_middleware(self, is_async: bool = False) -> None:
        super().load_middleware(is_async=False)

    async def get_response_async(self, request: HttpRequest) -> Any:
        return await sync_to_async(self.get_response, thread_sensitive=True)(request)


def get_asgi_application() -> OneHopASGIHandler:
    """``django.core.asgi.get_asgi_application`` with this handler."""
    import django

    django.setup(set_prefix=False)
    return OneHopASGIHandler()
