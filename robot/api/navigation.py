"""Map and navigation API: thin views over ``robot.navigation`` services and selectors."""

from __future__ import annotations

from typing import Any

from drf_spectacular.utils import extend_schema
from rest_framework import permissions, status, viewsets
from rest_framework.decorators import action
from rest_framework.request import Request
from rest_framework.response import Response

from cyborg_site.roles import is_operator
from robot.api.base import API_AUTHENTICATION, CommandThrottle, robot_api_view, run
from robot.api.common import error_responses
from robot.api.serializers_navigation import (
    Goal,
    InitialPoseResult,
    LocationSerializer,
    MapMeta,
    NavigationCancel,
    NavigationStatus,
    PoseInput,
)
from robot.api.validation import body_object
from robot.models import Location
from robot.navigation.goals import goal_cancel, goal_send, initial_pose_set
from robot.navigation.locations import location_go
from robot.navigation.selectors import map_meta, navigation_status


@extend_schema(responses={200: MapMeta, **error_responses(404)},
               summary="The latest map's metadata and versioned image URL")
@robot_api_view(["GET"])
def map_view(request: Request) -> Response:
    meta = map_meta()
    if meta is None:
        return Response({"detail": "No map has been received from the robot yet.", "code": "no_map"},
                        status=status.HTTP_404_NOT_FOUND)
    return Response(meta)


@extend_schema(request=PoseInput, responses={200: Goal, **error_responses(409, 503, 504)},
               summary="Send a navigation goal (move_base)",
               description="x and y in metres on the latest map (refused off the map, on obstacles or in "
                           "unexplored space), yaw in radians within (-2π, 2π]; other fields are refused.")
@robot_api_view(["POST"], commands=True)
def goal_view(request: Request) -> Response:
    command = goal_send(user=request.user, data=body_object(request))
    run(request, command)
    return Response(command.result)


@extend_schema(request=None, responses={200: NavigationCancel, **error_responses(503, 504)},
               summary="Cancel the current goal")
@robot_api_view(["POST"], commands=True)
def cancel_view(request: Request) -> Response:
    command = goal_cancel()
    return Response({"detail": run(request, command), **command.result})


@extend_schema(responses={200: NavigationStatus}, summary="The current goal, its status, and the robot's pose")
@robot_api_view(["GET"])
def status_view(request: Request) -> Response:
    return Response(navigation_status())


@extend_schema(request=PoseInput, responses={200: InitialPoseResult, **error_responses(409, 503, 504)},
               summary="Set the robot's initial pose",
               description="x and y in metres on the latest map (unexplored space allowed, obstacles not), yaw in "
                           "radians within (-2π, 2π]; other fields are refused.")
@robot_api_view(["POST"], commands=True)
def initial_pose_view(request: Request) -> Response:
    command = initial_pose_set(data=body_object(request))
    return Response({"detail": run(request, command), "pose": command.result})


class OperatorWrites(permissions.BasePermission):
    message = "Your role may not change locations (operators and admins can)."

    def has_permission(self, request: Request, view: Any) -> bool:
        return request.method in permissions.SAFE_METHODS or is_operator(request.user)


class LocationViewSet(viewsets.ModelViewSet):
    """Named locations: everyone lists them, operators create, edit, delete and send the robot there."""

    queryset = Location.objects.all()
    serializer_class = LocationSerializer
    lookup_field = "name"
    lookup_value_regex = r"[A-Za-z0-9_\-]+"
    permission_classes = [permissions.IsAuthenticated, OperatorWrites]
    authentication_classes = API_AUTHENTICATION

    @extend_schema(request=None, responses={200: Goal, **error_responses(409, 503, 504)},
                   summary="Send the robot to this location")
    @action(detail=True, methods=["post"], permission_classes=[permissions.IsAuthenticated],
            throttle_classes=[CommandThrottle])
    def go(self, request: Request, name: str) -> Response:
        # The command pipeline checks the role (and audits refusals), so no permission class here.
        command = location_go(user=request.user, name=name)
        run(request, command)
        return Response(command.result)
