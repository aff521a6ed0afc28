"""manage.py adduser: a role and a password the password validators accept, else a clear refusal."""

import pytest
from django.contrib.auth.models import User
from django.core.management import CommandError, call_command

pytestmark = pytest.mark.django_db


@pytest.mark.parametrize(("password", "reason"), [
    ("x", "too short"),
    ("12345678901234", "entirely numeric"),
    ("qwerty123456", "too common"),
    ("grace-hopper-1906", "too similar to the username"),
])
def test_it_refuses_a_password_the_validators_refuse_and_creates_no_one(password, reason):
    with pytest.raises(CommandError) as refused:
        call_command("adduser", "grace-hopper", "--role", "operator", "--password", password)
    assert str(refused.value).startswith("password refused: ") and reason in str(refused.value)
    assert not User.objects.filter(username="grace-hopper").exists()


def test_it_refuses_a_weak_password_for_an_existing_user_and_keeps_the_old_one():
    call_command("adduser", "grace", "--password", "correct-horse-battery")
    with pytest.raises(CommandError, match="at least 12 characters"):
        call_command("adduser", "grace", "--password", "short")
    assert User.objects.get(username="grace").check_password("correct-horse-battery")


def test_it_creates_a_user_with_a_good_password_or_a_random_one(capsys):
    call_command("adduser", "ada", "--role", "admin", "--password", "correct-horse-battery")
    ada = User.objects.get(username="ada")
    assert ada.is_staff and ada.check_password("correct-horse-battery")
    call_command("adduser", "vera")
    printed = capsys.readouterr().out.rsplit("password: ", 1)[1].strip()
    assert len(printed) >= 12 and User.objects.get(username="vera").check_password(printed)
