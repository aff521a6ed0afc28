"""The Content-Security-Policy of every response.

Scripts, styles, images and connections (websockets too: CSP3's 'self' covers ws: and wss: on the
page's own host and port) come from the site itself; no inline script, style or style attribute
(a page's data travels in ``json_script`` blocks, which are not run); no plugins, no framing, no
<base>, forms posted only here (and, with single sign-on, the logout's redirect on to the provider,
which browsers check against form-action too). Images may also be data: and blob: URLs.

A view that needs one thing more says so with ``csp_extend``: the state machine page compiles
Graphviz to WebAssembly (``'wasm-unsafe-eval'`` lets WebAssembly compile, not JavaScript's eval).
The policy is a constant, so a few lines here instead of a library; Django 6.0's own
``SECURE_CSP`` takes the same directives.
"""

from __future__ import annotations

import urllib.parse
from collections.abc import Callable, Mapping
from typing import Any, TypeVar

from django.conf import settings
from django.http import HttpRequest, HttpResponseBase

HEADER = "Content-Security-Policy"
POLICY: dict[str, tuple[str, ...]] = {
    "default-src": ("'self'",),
    "script-src": ("'self'",),
    "style-src": ("'self'",),
    "img-src": ("'self'", "data:", "blob:"),
    "connect-src": ("'self'",),
    "object-src": ("'none'",),
    "base-uri": ("'self'",),
    "frame-ancestors": ("'none'",),
    "form-action": ("'self'",),
}


def _origin(url: str) -> str:
    parts = urllib.parse.urlsplit(url)
    return f"{parts.scheme}://{parts.netloc}"


if settings.OIDC_ISSUER:
    POLICY["form-action"] += (_origin(settings.OIDC_ISSUER),)

View = TypeVar("View", bound=Callable[..., Any])


def policy_header(extra: Mapping[str, tuple[str, ...]] | None = None) -> str:
    """The header's value: ``POLICY`` with ``extra`` sources added to their directives."""
    directives = {name: (*sources, *(extra or {}).get(name, ())) for name, sources in POLICY.items()}
    return "; ".join(f"{name} {' '.join(sources)}" for name, sources in directives.items())


def csp_extend(**extra: tuple[str, ...]) -> Callable[[View], View]:
    """Add sources to directives for one view: ``@csp_extend(script_src=("'wasm-unsafe-eval'",))``."""

    def decorate(view: View) -> View:
        view.csp_extra = {name.replace("_", "-"): sources for name, sources in extra.items()}  # type: ignore[attr-defined]
        return view

    return decorate


DEFAULT = policy_header()


class ContentSecurityPolicyMiddleware:
    def __init__(self, get_response: Callable[[HttpRequest], HttpResponseBase]) -> None:
        self.get_response = get_response

    def __call__(self, request: HttpRequest) -> HttpResponseBase:
        response = self.get_response(request)
        extra = getattr(request, "_csp_extra", None)
        response.headers.setdefault(HEADER, policy_header(extra) if extra else DEFAULT)
        return response

    def process_view(self, request: HttpRequest, view_func: Callable[..., Any], view_args: Any,
                     view_kwargs: Any) -> None:
        request._csp_extra = getattr(view_func, "csp_extra", None)  # type: ignore[attr-defined]
