from typing import Any

from django.contrib.auth.models import User
from django.core.management.base import BaseCommand

from cyborg_site.roles import Role
from dashboard.accounts import create_user, ensure_role_groups
from history.defaults import ensure_default_policies


class Command(BaseCommand):
    help = ("First run: role groups, default recording policies and, if there is no admin yet, an 'admin' "
            "account whose password is printed.")

    def handle(self, *args: Any, **options: Any) -> None:
        ensure_role_groups()
        created = ensure_default_policies()
        if created:
            self.stdout.write(f"Recording {created} topics by default (change it in the admin: Topic policies).")
        if User.objects.filter(is_superuser=True).exists():
            self.stdout.write("Admin account exists; log in with it (reset: manage.py adduser admin --role admin).")
            return
        _, password = create_user("admin", Role.ADMIN)
        self.stdout.write(self.style.SUCCESS(f"Created the first admin. Log in as  admin / {password}"))
