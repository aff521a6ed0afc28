from django.contrib.auth.models import User
from django.core.management import call_command

from history.defaults import DEFAULT_POLICIES
from history.models import Mode, TopicPolicy
from robot import interface as ri


def test_it_creates_the_first_admin_once_and_prints_the_password(db, capsys):
    call_command("bootstrap")
    out = capsys.readouterr().out
    admin = User.objects.get(username="admin")
    assert admin.is_superuser and admin.is_staff
    password = out.split("admin / ")[1].split()[0]
    assert admin.check_password(password)
    call_command("bootstrap")
    assert "Admin account exists" in capsys.readouterr().out
    assert User.objects.count() == 1


def test_it_records_the_dashboard_topics_by_default_without_overriding_admins(db):
    battery = ri.topic("battery_soc").name
    TopicPolicy.objects.create(topic=battery, mode=Mode.OFF)
    call_command("bootstrap")
    assert TopicPolicy.objects.get(topic=battery).mode == Mode.OFF, "an admin's choice stays"
    assert TopicPolicy.objects.get(topic=ri.topic("state_change").name).mode == Mode.EVERY
    assert TopicPolicy.objects.count() == len(DEFAULT_POLICIES)
