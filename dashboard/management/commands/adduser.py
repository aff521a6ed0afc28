from argparse import ArgumentParser
from typing import Any

from django.core.management.base import BaseCommand, CommandError

from cyborg_site.roles import Role
from dashboard.accounts import create_user, password_problems


class Command(BaseCommand):
    help = "Create a user (or reset its password) with a role: viewer, operator or admin."

    def add_arguments(self, parser: ArgumentParser) -> None:
        parser.add_argument("username")
        parser.add_argument("--role", choices=[r.value for r in Role], default=Role.VIEWER.value)
        parser.add_argument("--password", help="At least 12 characters and not a common one (the password "
                                               "validators). Default: a random one, printed.")

    def handle(self, *args: Any, username: str, role: str, password: str | None, **options: Any) -> None:
        if not username.strip():
            raise CommandError("username must not be empty")
        problems = password_problems(password, username=username) if password is not None else []
        if problems:
            raise CommandError("password refused: " + " ".join(problems))
        _, password = create_user(username, Role(role), password=password)
        self.stdout.write(f"{role} {username!r} ready; password: {password}")
