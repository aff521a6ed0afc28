"""Logging in and out: the local form (with "Sign in with NAME" beside it when single sign-on is
configured), the way to the provider and back, and a logout that ends the provider's session too."""

from __future__ import annotations

from typing import Any

import requests
from django import forms
from django.contrib.auth import views as auth_views
from django.contrib.auth.decorators import login_not_required
from django.contrib.auth.forms import AuthenticationForm
from django.http import Http404, HttpRequest, HttpResponse, HttpResponseRedirect
from django.shortcuts import render
from django.urls import reverse
from django.utils.http import url_has_allowed_host_and_scheme
from django.views.decorators.cache import never_cache

from cyborg_site.roles import may_sign_in_with_password
from dashboard.sso.claims import ClaimsRefused
from dashboard.sso.client import REFUSALS, claims_from_callback, provider_logout_url, reason_of, redirect_to_provider
from dashboard.sso.config import SsoConfig, sso_config
from dashboard.sso.signin import ID_TOKEN_KEY, Refusal, refuse, sign_in

NEXT_KEY = "sso_next"


class PasswordLoginForm(AuthenticationForm):
    sso_required = ""  # why a right password was refused, for the page

    def confirm_login_allowed(self, user: Any) -> None:
        super().confirm_login_allowed(user)
        if not may_sign_in_with_password(user):
            config = sso_config()
            self.sso_required = (f"Sign in with {config.name if config else 'single sign-on'}: passwords here "
                                 "are for break-glass accounts only.")
            raise forms.ValidationError(self.sso_required, code="sso_required")


class LoginView(auth_views.LoginView):
    authentication_form = PasswordLoginForm
    redirect_authenticated_user = True

    def get_context_data(self, **kwargs: Any) -> dict[str, Any]:
        return {**super().get_context_data(**kwargs), "sso": sso_config()}


class LogoutView(auth_views.LogoutView):
    def post(self, request: HttpRequest, *args: Any, **kwargs: Any) -> HttpResponse:
        id_token = request.session.get(ID_TOKEN_KEY, "")
        response = super().post(request, *args, **kwargs)
        config = sso_config()
        if id_token and config:
            try:
                url = provider_logout_url(config, id_token=id_token, then=request.build_absolute_uri(reverse("login")))
            except REFUSALS:
                url = None  # the provider is away: this site's session has ended all the same
            if url:
                return HttpResponseRedirect(url)
        return response


def _config() -> SsoConfig:
    config = sso_config()
    if config is None:
        raise Http404("Single sign-on is not configured.")
    return config


@login_not_required
@never_cache
def sso_login(request: HttpRequest) -> HttpResponse:
    config = _config()
    wanted = request.GET.get("next", "")
    safe = url_has_allowed_host_and_scheme(wanted, allowed_hosts={request.get_host()},
                                           require_https=request.is_secure())
    request.session[NEXT_KEY] = wanted if safe else ""
    return redirect_to_provider(config, request, request.build_absolute_uri(reverse("sso-callback")))


@login_not_required
@never_cache
def sso_callback(request: HttpRequest) -> HttpResponse:
    config = _config()
    refusal: Refusal | None
    try:
        claims, id_token = claims_from_callback(config, request)
    except requests.RequestException as exc:  # the provider away: nobody's fault at this address
        refusal = refuse(request, {}, Refusal("provider_unreachable", f"{config.name} could not be reached "
                                              f"({reason_of(exc)}). Try again in a minute."), counts=False)
    except REFUSALS as exc:
        refusal = refuse(request, {}, Refusal("not_verified", f"The sign-in could not be verified ({reason_of(exc)}). "
                                                              "Start again from the login page."), counts=True)
    except ClaimsRefused as exc:
        refusal = refuse(request, {}, Refusal("claims_refused", f"Your claims from {config.name} could not be "
                                              f"completed: {exc.reason}."), counts=exc.forged)
    else:
        refusal = sign_in(request, config, claims, id_token)
    if refusal is not None:
        return render(request, "registration/sso_refused.html", {"refusal": refusal, "sso": config},
                      status=refusal.status)
    return HttpResponseRedirect(request.session.pop(NEXT_KEY, "") or reverse("dashboard:home"))
