from typing import Any

from django.apps import AppConfig
from django.core import checks
from django.db.models.signals import post_migrate


def sso_settings_check(**kwargs: Any) -> list[checks.CheckMessage]:
    from dashboard.sso.config import config_problems

    return [checks.Error(f"Single sign-on: {problem}.", id="dashboard.E001") for problem in config_problems()]


class DashboardConfig(AppConfig):
    name = "dashboard"
    default_auto_field = "django.db.models.BigAutoField"

    def ready(self) -> None:
        from axes.signals import user_locked_out

        from dashboard.accounts import ensure_role_groups
        from dashboard.lockouts import audit_lockout

        checks.register(sso_settings_check)
        post_migrate.connect(lambda **kwargs: ensure_role_groups(), sender=self, weak=False)
        user_locked_out.connect(audit_lockout, dispatch_uid="dashboard.audit_lockout")
        import dashboard.access_audit  # its receivers: access and settings changes are audited
        import dashboard.login_flood  # its receiver: the browser an account logged in from
        import dashboard.revocation  # its receivers: access changes reach open sockets
        import dashboard.sessions  # noqa: F401  (its receivers: each person's sessions are recorded)
        import robot.api.tokens  # noqa: F401  (its receivers: a password change ends the tokens)
