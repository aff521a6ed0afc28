from django.apps import AppConfig


class ServerConfig(AppConfig):
    name = "server"

    def ready(self) -> None:
        from server.patches.releases import SERVER_PATCHES

        SERVER_PATCHES.register_check()
