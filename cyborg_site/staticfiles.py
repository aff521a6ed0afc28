"""Static files: content-hashed names for production, so the proxy can let browsers keep them for a
year; and WhiteNoise as an async middleware.

WhiteNoise's middleware is synchronous only. In front of async views Django adapts it by running
it, and everything below it, on the one shared sync thread: every API request and page queued
there (bench/api_throughput.py). ``AsyncWhiteNoiseMiddleware`` serves requests under
``STATIC_URL`` through WhiteNoise as before and sends every other request on without a thread hop.
"""

from __future__ import annotations

from asgiref.sync import markcoroutinefunction, sync_to_async
from django.conf import settings
from django.contrib.staticfiles.storage import ManifestStaticFilesStorage
from whitenoise.middleware import WhiteNoiseMiddleware


class HashedStaticFiles(ManifestStaticFilesStorage):
    # The pages' JavaScript modules import each other ("./live.js", import("./commands.js")):
    # rewrite those references too, or a browser would pair a new module with a cached old one.
    support_js_module_import_aggregation = True


class AsyncWhiteNoiseMiddleware(WhiteNoiseMiddleware):
    sync_capable = False
    async_capable = True

    def __init__(self, get_response, settings=settings) -> None:
        super().__init__(get_response, settings)
        markcoroutinefunction(self)

    async def __call__(self, request):  # type: ignore[override]
        path = request.path_info
        if path.startswith(self.static_prefix) or getattr(settings, "WHITENOISE_ROOT", None):
            # With autorefresh (development) the lookup walks the disk: keep it off the event loop.
            static_file = (await sync_to_async(self.find_file, thread_sensitive=False)(path) if self.autorefresh
                           else self.files.get(path))
            if static_file is not None:
                return self.serve(static_file, request)
        return await self.get_response(request)
