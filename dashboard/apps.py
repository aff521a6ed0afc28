from django.apps import AppConfig
from django.db.models.signals import post_migrate


class DashboardConfig(AppConfig):
    name = "dashboard"
    default_auto_field = "django.db.models.BigAutoField"

    def ready(self) -> None:
        from dashboard.accounts import ensure_role_groups

        post_migrate.connect(lambda **kwargs: ensure_role_groups(), sender=self, weak=False)
