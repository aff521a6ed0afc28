from django.contrib.auth.models import User
from django.core.management.base import BaseCommand

from cyborg_site.roles import Role
from dashboard.accounts import create_user, ensure_role_groups


class Command(BaseCommand):
    help = "First run: role groups and, if there is no admin yet, an 'admin' account whose password is printed."

    def handle(self, *args, **options) -> None:
        ensure_role_groups()
        if User.objects.filter(is_superuser=True).exists():
            self.stdout.write("Admin account exists; log in with it (reset: manage.py adduser admin --role admin).")
            return
        _, password = create_user("admin", Role.ADMIN)
        self.stdout.write(self.style.SUCCESS(f"Created the first admin. Log in as  admin / {password}"))
