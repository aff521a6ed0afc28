from django.contrib.auth.middleware import LoginRequiredMiddleware as _DjangoLoginRequired

# The API answers anonymous callers itself (401/403 JSON, token auth); static files and
# the admin have their own handling.
_EXEMPT_PREFIXES = ("/api/", "/static/", "/admin/")


class LoginRequiredMiddleware(_DjangoLoginRequired):
    def process_view(self, request, view_func, view_args, view_kwargs):
        if request.path.startswith(_EXEMPT_PREFIXES):
            return None
        return super().process_view(request, view_func, view_args, view_kwargs)
