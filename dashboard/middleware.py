from collections.abc import Callable
from typing import Any

from django.contrib.auth.middleware import LoginRequiredMiddleware as _DjangoLoginRequired
from django.http import HttpRequest, HttpResponseBase

# The API answers anonymous callers itself (401/403 JSON, token auth); static files and
# the admin have their own handling.
_EXEMPT_PREFIXES = ("/api/", "/static/", "/admin/")


class LoginRequiredMiddleware(_DjangoLoginRequired):
    def process_view(self, request: HttpRequest, view_func: Callable[..., Any], view_args: Any,
                     view_kwargs: Any) -> HttpResponseBase | None:
        # Open views first: /healthz must not load the session (the database may be down).
        if request.path.startswith(_EXEMPT_PREFIXES) or not getattr(view_func, "login_required", True):
            return None
        return super().process_view(request, view_func, view_args, view_kwargs)
