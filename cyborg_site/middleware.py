"""Django's own middleware without a thread hop per hook on async requests.

In async mode Django's ``MiddlewareMixin`` runs every ``process_request`` and ``process_response``
through ``sync_to_async`` on the one shared sync thread: about a dozen hops for each request,
which capped the async state API at the speed of that thread (bench/api_throughput.py, py-spy).
These subclasses run the hooks that only read and write the request and response (headers,
cookies, lazy objects) on the event loop, and hop to the thread only when a hook may touch the
database: a session or message store that was used during the request.
"""

from __future__ import annotations

from typing import Any

from asgiref.sync import sync_to_async
from django.contrib.auth import middleware as auth
from django.contrib.messages import middleware as messages
from django.contrib.sessions import middleware as sessions
from django.middleware import clickjacking, common, csrf, security


class InlineHooks:
    """``process_request``/``process_response`` run on the event loop unless ``needs_thread`` says otherwise."""

    def needs_thread(self, request: Any) -> bool:
        return False

    async def __acall__(self, request: Any) -> Any:
        response = self.process_request(request) if hasattr(self, "process_request") else None
        response = response or await self.get_response(request)  # type: ignore[attr-defined]
        if hasattr(self, "process_response"):
            if self.needs_thread(request):
                response = await sync_to_async(self.process_response, thread_sensitive=True)(request, response)
            else:
                response = self.process_response(request, response)
        return response


class SecurityMiddleware(InlineHooks, security.SecurityMiddleware):
    pass


class CommonMiddleware(InlineHooks, common.CommonMiddleware):
    pass


class XFrameOptionsMiddleware(InlineHooks, clickjacking.XFrameOptionsMiddleware):
    pass


class CsrfViewMiddleware(InlineHooks, csrf.CsrfViewMiddleware):
    # Cookie-based tokens (CSRF_USE_SESSIONS is off): the hooks read and set cookies only.
    async def process_view(self, request: Any, callback: Any, callback_args: Any, callback_kwargs: Any) -> Any:
        return super().process_view(request, callback, callback_args, callback_kwargs)


class AuthenticationMiddleware(InlineHooks, auth.AuthenticationMiddleware):
    pass  # sets a lazy request.user; nothing is queried until a view asks


class SessionMiddleware(InlineHooks, sessions.SessionMiddleware):
    def needs_thread(self, request: Any) -> bool:
        return request.session.accessed  # saving or deleting a used session writes the store


class MessageMiddleware(InlineHooks, messages.MessageMiddleware):
    def needs_thread(self, request: Any) -> bool:
        store = getattr(request, "_messages", None)
        return store is not None and (store.used or store.added_new)
