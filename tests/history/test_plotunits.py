"""Every plot's value axis names a unit where one is known: battery in %, positions in m, speeds in m/s."""

from history.plotunits import unit_of, units_of


def test_it_plots_the_battery_in_percent():
    assert unit_of("/RosAria/battery_state_of_charge", "data") == {"unit": "%", "scale": 100.0}
    assert unit_of("/RosAria/battery_voltage", "data") == {"unit": "V", "scale": 1.0}


def test_it_knows_units_from_a_fields_path_on_any_topic():
    assert units_of("/odom", ["pose.pose.position.x", "twist.twist.linear.x", "twist.twist.angular.z",
                              "header.seq", "child_frame_id"]) == {
        "pose.pose.position.x": {"unit": "m", "scale": 1.0}, "twist.twist.linear.x": {"unit": "m/s", "scale": 1.0},
        "twist.twist.angular.z": {"unit": "rad/s", "scale": 1.0}, "header.seq": {"unit": "count", "scale": 1.0}}


def test_it_names_no_unit_it_does_not_know():
    assert unit_of("/test/level", "data") is None
