"""Runs the tests' OpenID Connect provider: ``python -m tests.oidc_provider.serve --port P --data DIR``
(from the repository root). Migrates its own SQLite file in DIR, creates the users and the one client
that DIR/spec.json names, and serves on 127.0.0.1:P with a threaded WSGI server until killed."""

from __future__ import annotations

import argparse
import os
import sqlite3
import tempfile
import threading
import time
from contextlib import closing
from pathlib import Path


def _copy_database(source: Path, target: Path) -> None:
    with closing(sqlite3.connect(source)) as origin, closing(sqlite3.connect(target)) as copy:
        origin.backup(copy)


def _migrate(database: Path) -> None:
    """Copies a database migrated once per Django and DOT release (kept in the temp folder): the
    migrations take seconds, the copy milliseconds."""
    import django
    import oauth2_provider
    from django.core.management import call_command
    from django.db import connection

    template = Path(tempfile.gettempdir()) / f"oidc-provider-{django.__version__}-{oauth2_provider.__version__}.sqlite3"
    if template.exists():
        _copy_database(template, database)
        return
    call_command("migrate", verbosity=0, interactive=False)
    connection.close()
    partial = template.with_suffix(f".{os.getpid()}.partial")
    _copy_database(database, partial)
    partial.replace(template)


def _populate(spec: dict) -> None:
    from django.contrib.auth.models import User
    from oauth2_provider.models import get_application_model

    for user in spec["users"]:
        User.objects.create_user(user["username"], user["email"], user["password"])
    client = spec["client"]
    get_application_model().objects.create(
        name="Cyborg Commander (tests)",
        client_id=client["client_id"],
        client_secret=client["client_secret"],
        client_type="confidential",
        authorization_grant_type="authorization-code",
        redirect_uris=" ".join(client["redirect_uris"]),
        post_logout_redirect_uris=" ".join(client["post_logout_redirect_uris"]),
        algorithm="RS256",
        skip_authorization=True,
    )


def _exit_with(parent: int) -> None:
    """Ends this process once the test process that started it is gone, however it went."""
    while os.getppid() == parent:
        time.sleep(1)
    os._exit(0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--port", type=int, required=True)
    parser.add_argument("--data", type=Path, required=True)
    args = parser.parse_args()
    os.environ["DJANGO_SETTINGS_MODULE"] = "tests.oidc_provider.settings"
    os.environ["OIDC_PROVIDER_PORT"] = str(args.port)
    os.environ["OIDC_PROVIDER_DATA"] = str(args.data.resolve())

    import django
    from django.conf import settings
    from django.core.servers.basehttp import ThreadedWSGIServer, WSGIRequestHandler
    from django.core.wsgi import get_wsgi_application

    django.setup()
    _migrate(settings.DATABASES["default"]["NAME"])
    _populate(settings.SPEC)
    threading.Thread(target=_exit_with, args=(os.getppid(),), daemon=True).start()
    server = ThreadedWSGIServer(("127.0.0.1", args.port), WSGIRequestHandler)
    server.set_app(get_wsgi_application())
    print(f"OIDC provider at {settings.ISSUER}", flush=True)
    server.serve_forever()


if __name__ == "__main__":
    main()
