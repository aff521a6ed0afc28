from django.apps import AppConfig


class AlertsConfig(AppConfig):
    name = "robot.alerts"
    label = "alerts"
    default_auto_field = "django.db.models.BigAutoField"

    def ready(self) -> None:
        from robot.alerts import delivery, engine

        engine.install()  # raised where the link runs, shown on every page
        delivery.install()  # and sent beyond the tab from there
