from django.apps import AppConfig


class HistoryConfig(AppConfig):
    name = "history"
    default_auto_field = "django.db.models.BigAutoField"

    def ready(self) -> None:
        from history.blackbox import run_blackbox
        from history.camerarec import run_camera_recorder
        from history.recorder import run_recorder
        from history.retention import run_pruning
        from robot.link.hosting import register_background

        # The recorder (history's one way in) runs wherever the link runs; with REDIS_URL, Celery beat prunes.
        register_background("history-recorder", run_recorder)
        register_background("history-pruning", run_pruning, embedded_only=True)
        register_background("history-camera", run_camera_recorder)
        register_background("history-blackbox", run_blackbox)
