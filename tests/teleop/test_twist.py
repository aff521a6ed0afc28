"""Input state → clamped Twist (pure functions)."""

import math

import pytest

from robot.teleop.twist import Command, InvalidInput, Limits, command_from_input, twist

LIMITS = Limits(linear=0.5, angular=1.0)


def test_it_scales_normalised_input_by_the_slider_maxima():
    command = command_from_input({"linear": 0.5, "angular": -1, "max_linear": 0.4, "max_angular": 0.8}, LIMITS)
    assert command == Command(linear=0.2, angular=-0.8)


def test_it_caps_sliders_and_input_at_the_server_limits():
    command = command_from_input({"linear": 7, "angular": -3, "max_linear": 99, "max_angular": 50}, LIMITS)
    assert command == Command(linear=0.5, angular=-1.0)


def test_it_uses_the_server_limits_when_the_page_sends_no_sliders():
    assert command_from_input({"linear": 1, "angular": 1}, LIMITS) == Command(0.5, 1.0)


def test_it_treats_negative_slider_values_as_zero():
    assert command_from_input({"linear": 1, "angular": 1, "max_linear": -2}, LIMITS).linear == 0.0


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf, "1", None, True, [1], {"x": 1}])
@pytest.mark.parametrize("field", ["linear", "angular", "max_linear"])
def test_it_rejects_non_finite_and_non_numeric_values(field, bad):
    content = {"linear": 0.5, "angular": 0.5, field: bad}  # a missing slider is allowed, a null one is not
    with pytest.raises(InvalidInput):
        command_from_input(content, LIMITS)


def test_it_builds_a_planar_twist_with_positive_zeros():
    message = twist(command_from_input({"linear": -0.0, "angular": 0}, LIMITS))
    assert message == {"linear": {"x": 0.0, "y": 0.0, "z": 0.0}, "angular": {"x": 0.0, "y": 0.0, "z": 0.0}}
    assert math.copysign(1, message["linear"]["x"]) == 1
