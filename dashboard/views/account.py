"""The signed-in person's own page: their address for alerts and which alerts reach them, their API
token, their password and their sessions. Thin: each form calls one service and the page says how
it went (a notice on success, the reason on error)."""

from __future__ import annotations

from typing import Any

from django.contrib.auth import update_session_auth_hash
from django.contrib.auth.forms import PasswordChangeForm
from django.contrib.auth.models import User
from django.http import HttpRequest, HttpResponse
from django.urls import reverse
from django.views.decorators.http import require_POST
from rest_framework import serializers
from rest_framework.authtoken.models import Token

from cyborg_site.rendering import render_safe
from dashboard.sessions import session_end, session_rekeyed, sessions_end_others, sessions_of
from robot.alerts.addresses import alert_address_forget, alert_address_request, alert_address_verify
from robot.alerts.choices import alert_choice, alert_choice_set
from robot.alerts.models import KINDS, Alert, AlertChoice
from robot.api.tokens import expires_at, token_create, token_revoke


def _problem(exc: serializers.ValidationError) -> str:
    detail = exc.detail
    if isinstance(detail, dict):
        return "; ".join(f"{name.replace('_', ' ')}: {', '.join(map(str, problems))}"
                         for name, problems in detail.items())
    return " ".join(map(str, detail))


def _person(request: HttpRequest) -> User:
    assert isinstance(request.user, User)  # every page is behind LoginRequiredMiddleware
    return request.user


def _page(request: HttpRequest, *, notice: str = "", error: str = "", status: int | None = None,
          password_form: PasswordChangeForm | None = None, **extra: Any) -> HttpResponse:
    user = _person(request)
    token = Token.objects.filter(user=user).first()
    choice = AlertChoice.objects.filter(user=user).first()
    response = render_safe(request, "dashboard/account.html", {
        "notice": notice, "error": error,
        "choice": alert_choice(user),
        "own_email": choice.email if choice else "",
        "kinds": KINDS, "severities": Alert.Severity.values,
        "token": token, "token_expires": expires_at(token) if token else None,
        "has_password": user.has_usable_password(),
        "password_form": password_form or PasswordChangeForm(user),
        "sessions": sessions_of(user=user), "current_key": request.session.session_key,
        **extra,
    })
    response.status_code = status or (400 if error else 200)
    return response


def account(request: HttpRequest) -> HttpResponse:
    return _page(request)


@require_POST
def account_email(request: HttpRequest) -> HttpResponse:
    if "forget" in request.POST:
        alert_address_forget(user=request.user)
        return _page(request, notice="Alerts by e-mail go to your account's address again.")
    address = request.POST.get("email", "")
    try:
        alert_address_request(user=request.user, address=address, link=lambda token: request.build_absolute_uri(
            reverse("dashboard:account-email-verify", args=[token])))
    except serializers.ValidationError as exc:
        return _page(request, error=_problem(exc))
    return _page(request, notice=f"We sent a link to {address.strip()}: open it to get alerts there.")


def account_email_verify(request: HttpRequest, token: str) -> HttpResponse:
    try:
        address = alert_address_verify(user=request.user, token=token)
    except serializers.ValidationError as exc:
        return _page(request, error=_problem(exc))
    return _page(request, notice=f"Confirmed: alerts by e-mail go to {address}.")


@require_POST
def account_alerts(request: HttpRequest) -> HttpResponse:
    changes = {"by_email": "by_email" in request.POST, "by_push": "by_push" in request.POST,
               "kinds": request.POST.getlist("kinds"), "min_severity": request.POST.get("min_severity", "")}
    try:
        alert_choice_set(request.user, changes)
    except serializers.ValidationError as exc:
        return _page(request, error=_problem(exc))
    return _page(request, notice="Your alert choices are saved.")


@require_POST
def account_token(request: HttpRequest) -> HttpResponse:
    if "revoke" in request.POST:
        if token_revoke(user=request.user):
            return _page(request, notice="Your API token is revoked: it works no more.")
        return _page(request, error="You have no API token to revoke.")
    try:
        token = token_create(user=request.user, days=float(request.POST.get("days", "")))
    except ValueError:
        return _page(request, error="days: a number")
    except serializers.ValidationError as exc:
        return _page(request, error=_problem(exc))
    return _page(request, notice="Your new API token is below: copy it now, it is shown only this once.",
                 new_token=token.key)


@require_POST
def account_password(request: HttpRequest) -> HttpResponse:
    if not _person(request).has_usable_password():
        return _page(request, error="Your account signs in through single sign-on: it has no password here.")
    form = PasswordChangeForm(request.user, request.POST)
    if not form.is_valid():
        problems = " ".join(str(message) for errors in form.errors.values() for message in errors)
        return _page(request, error=f"Password not changed: {problems}", password_form=form)
    old_key = request.session.session_key or ""
    update_session_auth_hash(request, form.save())
    session_rekeyed(old_key=old_key, new_key=request.session.session_key or "")
    return _page(request, notice="Your password is changed; your other sessions and your API token have ended.")


@require_POST
def account_sessions(request: HttpRequest) -> HttpResponse:
    current = request.session.session_key or ""
    if "others" in request.POST:
        ended = sessions_end_others(user=request.user, current_key=current)
        return _page(request, notice=f"Ended {ended} other session{'' if ended == 1 else 's'}.")
    try:
        session_end(user=request.user, record_id=request.POST.get("session", ""), current_key=current)
    except serializers.ValidationError as exc:
        return _page(request, error=_problem(exc))
    return _page(request, notice="That session has ended: it is signed out.")
