"""Who may do what is audited like a command: accounts made, changed or deleted, roles given or
taken, passwords and API tokens, lockouts cleared, and the robot's named settings (locations,
emotion presets, sounds, dome modes). Whoever changes them (a page, the admin, the API, a
management command), a receiver here writes the entry; the person is the request's
(``ActorMiddleware``), else the entry says the system did it."""

from __future__ import annotations

from collections.abc import Callable
from contextvars import ContextVar
from typing import Any

from axes.models import AccessAttempt
from django.contrib.auth import get_user_model
from django.db import connection, transaction
from django.db.models import Model
from django.db.models.signals import m2m_changed, post_delete, post_save, pre_save
from django.dispatch import receiver
from django.http import HttpRequest, HttpResponseBase
from rest_framework.authtoken.models import Token

from dashboard.accounts import role_holders
from robot.api.errors import is_api_path
from robot.commands.audit import audit_record
from robot.models import DomeMode, EmotionPreset, Location, SoundClip

User = get_user_model()
ACCOUNT_FIELDS = ("username", "is_active", "is_staff", "is_superuser")
_request: ContextVar[HttpRequest | None] = ContextVar("access_audit_request", default=None)


class ActorMiddleware:
    """Makes the request (and so, once authenticated, its user) known to the receivers below."""

    def __init__(self, get_response: Callable[[HttpRequest], HttpResponseBase]) -> None:
        self.get_response = get_response

    def __call__(self, request: HttpRequest) -> HttpResponseBase:
        token = _request.set(request)
        try:
            return self.get_response(request)
        finally:
            _request.reset(token)


def _record(action: str, params: dict[str, Any], outcome: str, *, fallback_user: Any = None) -> None:
    request = _request.get()
    user = getattr(request, "user", None) if request is not None else None
    if user is None or not user.is_authenticated:
        user = fallback_user
    source = "system" if request is None else "api" if is_api_path(request.path) else "page"
    audit_record(user=user, source=source, action=action, params=params, ok=True, outcome=outcome)


def _fields(instance: Model, names: tuple[str, ...]) -> dict[str, Any]:
    return {name: getattr(instance, name) for name in names}


@receiver(pre_save, sender=User)
def _account_before(sender: type, instance: Any, **kwargs: Any) -> None:
    old = User.objects.filter(pk=instance.pk).values(*ACCOUNT_FIELDS, "password").first() if instance.pk else None
    instance._audit_before = old


@receiver(post_save, sender=User)
def _account_after(sender: type, instance: Any, created: bool, **kwargs: Any) -> None:
    old = getattr(instance, "_audit_before", None)
    name = instance.get_username()
    if created or old is None:
        _record("account.created", {"username": name, **_fields(instance, ACCOUNT_FIELDS[1:])},
                f"account {name} created")
        return
    now = _fields(instance, ACCOUNT_FIELDS)
    changed = {k: {"from": old[k], "to": v} for k, v in now.items() if old[k] != v}
    if changed:
        _record("account.changed", {"username": name, "changes": changed},
                f"account {name}: {', '.join(changed)} changed")
    if old["password"] != instance.password:
        _record("account.password", {"username": name}, f"password of {name} changed")


@receiver(post_delete, sender=User)
def _account_deleted(sender: type, instance: Any, **kwargs: Any) -> None:
    _record("account.deleted", {"username": instance.get_username()}, f"account {instance.get_username()} deleted")


def _role_names(user: Any) -> list[str]:
    return sorted(user.groups.values_list("name", flat=True))


@receiver(m2m_changed, sender=User.groups.through)
def _roles_changed(sender: type, instance: Any, action: str, reverse: bool, pk_set: set[Any] | None,
                   **kwargs: Any) -> None:
    """Each person's roles before the change (kept on ``instance``: a user, or a group when changed
    from the group's side) and after it."""
    users = role_holders(instance, action, reverse, pk_set)
    if action.startswith("pre_"):
        instance._audit_roles = {user.pk: _role_names(user) for user in users}
        return
    before = getattr(instance, "_audit_roles", {})
    for user in users:
        if user.pk in before:
            _roles_settle(user, before[user.pk])


def _roles_settle(user: Any, before: list[str]) -> None:
    """One entry per person and transaction: ``groups.set()`` removes, then adds."""
    pending = connection.__dict__.setdefault("_audit_roles_pending", {})
    waiting = pending.get(user.pk)
    if waiting is not None and any(entry[1] is waiting[1] for entry in connection.run_on_commit):
        return  # this transaction's entry is still to be written
    # (else: none, or a rolled-back transaction's, whose record was dropped with it)

    def record() -> None:
        was, now = pending.pop(user.pk, (before,))[0], _role_names(user)
        if was != now:
            _record("account.roles", {"username": user.get_username(), "from": was, "to": now},
                    f"roles of {user.get_username()}: {', '.join(now) or 'none'}")

    pending[user.pk] = (before, record)
    transaction.on_commit(record)


@receiver(post_save, sender=Token)
def _token_made(sender: type, instance: Token, created: bool, **kwargs: Any) -> None:
    if created:
        name = instance.user.get_username()
        _record("token.created", {"username": name}, f"API token of {name} made", fallback_user=instance.user)


@receiver(post_delete, sender=Token)
def _token_deleted(sender: type, instance: Token, **kwargs: Any) -> None:
    name = instance.user.get_username()
    _record("token.deleted", {"username": name}, f"API token of {name} deleted")


@receiver(post_delete, sender=AccessAttempt)
def _lockout_cleared(sender: type, instance: AccessAttempt, **kwargs: Any) -> None:
    request = _request.get()
    user = getattr(request, "user", None)
    if user is None or not user.is_authenticated or user.get_username() == instance.username:
        return  # a successful login resets its own failures; only a person clearing them is news
    _record("login.lockout_cleared", {"username": instance.username or "", "ip_address": instance.ip_address or ""},
            f"login failures of {instance.username or '?'} from {instance.ip_address or '?'} cleared")


SETTINGS_MODELS: tuple[type[Model], ...] = (Location, EmotionPreset, SoundClip, DomeMode)


def _setting_row(instance: Model) -> dict[str, Any]:
    return {f.name: getattr(instance, f.attname) for f in instance._meta.concrete_fields
            if f.name not in ("id", "created", "updated") and not f.auto_created}


def _setting_before(sender: type[Model], instance: Model, **kwargs: Any) -> None:
    old = sender._default_manager.filter(pk=instance.pk).first() if instance.pk else None
    instance._audit_before = _setting_row(old) if old is not None else None  # type: ignore[attr-defined]


def _setting_after(sender: type[Model], instance: Model, created: bool, **kwargs: Any) -> None:
    before, after = getattr(instance, "_audit_before", None), _setting_row(instance)
    if before == after:
        return
    kind = sender._meta.verbose_name
    _record("setting.changed", {"kind": str(kind), "name": str(instance), "from": before, "to": after},
            f"{kind} {instance} {'added' if before is None else 'changed'}")


def _setting_deleted(sender: type[Model], instance: Model, **kwargs: Any) -> None:
    kind = sender._meta.verbose_name
    _record("setting.changed", {"kind": str(kind), "name": str(instance), "from": _setting_row(instance), "to": None},
            f"{kind} {instance} removed")


for _model in SETTINGS_MODELS:
    pre_save.connect(_setting_before, sender=_model, dispatch_uid=f"audit-before-{_model.__name__}")
    post_save.connect(_setting_after, sender=_model, dispatch_uid=f"audit-after-{_model.__name__}")
    post_delete.connect(_setting_deleted, sender=_model, dispatch_uid=f"audit-deleted-{_model.__name__}")
