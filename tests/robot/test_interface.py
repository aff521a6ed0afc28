import pytest

from robot import interface as ri


def test_it_applies_topic_overrides_from_settings(settings):
    settings.ROBOT_TOPICS = {"cmd_vel": "/RosAria/cmd_vel"}
    ri.reload()
    assert ri.topic("cmd_vel").name == "/RosAria/cmd_vel"
    assert ri.topic("cmd_vel").type == "geometry_msgs/Twist"
    assert ri.topic_by_name("/RosAria/cmd_vel").key == "cmd_vel"


def test_it_rejects_overrides_for_unknown_keys(settings):
    settings.ROBOT_TOPICS = {"no_such_topic": "/x"}
    ri.reload()
    with pytest.raises(KeyError, match="no_such_topic"):
        ri.topics()


def test_it_maps_api_mode_names_to_robot_strings():
    assert ri.Mode.from_short("manual") is ri.Mode.MANUAL
    assert ri.Mode.MANUAL.value == "manual control"
    with pytest.raises(ValueError):
        ri.Mode.from_short("dance")


def test_it_reports_bad_overrides_as_a_system_check(settings):
    from robot.apps import check_robot_settings

    settings.ROBOT_SERVICES = {"nope": "/x"}
    settings.ROSBRIDGE_URL = "http://robot:9090"
    ids = {e.id for e in check_robot_settings(None)}
    assert ids == {"robot.E001", "robot.E003"}
