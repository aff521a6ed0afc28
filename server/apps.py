from django.apps import AppConfig
from django.core import checks


class ServerConfig(AppConfig):
    name = "server"

    def ready(self) -> None:
        from server.patches.releases import check_patched_server_releases

        checks.register(check_patched_server_releases)
