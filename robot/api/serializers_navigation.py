"""Shapes of the map and navigation API (input is checked again by the services)."""

from __future__ import annotations

from typing import Any

from asgiref.sync import async_to_sync
from rest_framework import serializers

from robot.api.common import same, shape
from robot.api.validation import reject_unknown
from robot.models import Location
from robot.navigation.locations import acurrent_pose
from robot.navigation.validation import YAW_LIMIT

# Named locations are on a building's map: coordinates within 10 km, arrival radius within 100 m.
COORDINATE_LIMIT_M = 10_000.0
THRESHOLD_MAX_M = 100.0
_COORDINATE = {"required": False, "min_value": -COORDINATE_LIMIT_M, "max_value": COORDINATE_LIMIT_M,
               "help_text": f"metres, map frame, within ±{COORDINATE_LIMIT_M:g}"}


class PoseInput(serializers.Serializer):
    x = serializers.FloatField(help_text="metres, map frame; must be on the latest map")
    y = serializers.FloatField(help_text="metres, map frame; must be on the latest map")
    yaw = serializers.FloatField(required=False, default=0.0, min_value=-YAW_LIMIT, max_value=YAW_LIMIT,
                                 help_text="heading in radians within (-2π, 2π] (0 = +x, CCW)")


Pose = shape("RobotPose", **same(serializers.FloatField, "x", "y", "yaw"))
MapMeta = shape(
    "MapMeta", version=serializers.CharField(), **same(serializers.IntegerField, "width", "height", help_text="cells"),
    resolution=serializers.FloatField(help_text="metres per cell"),
    origin=Pose(help_text="map position of the grid's bottom-left corner"), frame=serializers.CharField(),
    image_url=serializers.CharField(), received=serializers.FloatField(help_text="epoch seconds"))
Goal = shape(
    "Goal", **same(serializers.CharField, "id", "status_text"),
    by=serializers.CharField(help_text='who sent it: a user, or "another tool" for a goal this product did not send'),
    action=serializers.CharField(help_text="move_base or navigation"),
    **same(serializers.FloatField, "x", "y", "yaw", allow_null=True,
           help_text="the target; null for a goal another tool sent (the robot's goal status does not say)"),
    sent=serializers.FloatField(help_text="epoch seconds: sent, or first listed by the robot"),
    location=serializers.CharField(allow_null=True),
    foreign=serializers.BooleanField(help_text="another tool sent this goal, not this product"),
    status=serializers.CharField(help_text="pending, active, succeeded, aborted, cancelled, cancelling, …"))
InitialPoseResult = shape("InitialPoseResult", detail=serializers.CharField(), pose=Pose())
NavigationStatus = shape(
    "NavigationStatus", goal=Goal(allow_null=True), robot_pose=Pose(allow_null=True),
    **same(serializers.CharField, "current_location", "map_version", allow_null=True), backend=serializers.CharField())
NavigationCancel = shape(
    "NavigationCancel", goal=Goal(allow_null=True), robot_pose=Pose(allow_null=True),
    **same(serializers.CharField, "current_location", "map_version", allow_null=True), backend=serializers.CharField(),
    detail=serializers.CharField(), cancel_sent=serializers.BooleanField(
        help_text="A goal was under way and the cancel went out for it (it may show as ended already)."))


class LocationSerializer(serializers.ModelSerializer):
    use_current_pose = serializers.BooleanField(
        write_only=True, required=False, default=False,
        help_text="take x, y and yaw from the robot's current pose",
    )

    class Meta:
        model = Location
        fields = ("name", "map_name", "x", "y", "yaw", "threshold", "description", "use_current_pose")
        extra_kwargs = {"x": _COORDINATE, "y": _COORDINATE,
                        "yaw": {"min_value": -YAW_LIMIT, "max_value": YAW_LIMIT,
                                "help_text": "heading in radians within (-2π, 2π]"},
                        "threshold": {"max_value": THRESHOLD_MAX_M, "help_text": "arrival radius, metres"}}

    def to_internal_value(self, data: Any) -> Any:
        if isinstance(data, dict):
            reject_unknown(data, [name for name, field in self.fields.items() if not field.read_only])
        return super().to_internal_value(data)

    def validate_yaw(self, value: float) -> float:
        if value <= -YAW_LIMIT:
            raise serializers.ValidationError("must be within (-2π, 2π]")
        return value

    def validate(self, attrs: dict[str, Any]) -> dict[str, Any]:
        if attrs.pop("use_current_pose", False):
            attrs.update(async_to_sync(acurrent_pose)())
        elif self.instance is None and ("x" not in attrs or "y" not in attrs):
            field = "x" if "x" not in attrs else "y"
            raise serializers.ValidationError({field: ["This field is required (or set use_current_pose)."]})
        return attrs
