"""Replay and incident API (under /api/history/): thin views over ``history.replay`` and ``history.incidents``."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from django.forms.models import model_to_dict
from django.http import FileResponse, Http404, HttpResponse
from django.urls import reverse
from drf_spectacular.types import OpenApiTypes
from drf_spectacular.utils import OpenApiParameter, extend_schema
from rest_framework import exceptions, status
from rest_framework.decorators import api_view
from rest_framework.request import Request
from rest_framework.response import Response

from cyborg_site.roles import is_admin, is_operator
from cyborg_site.text import clean_text
from history import replay
from history.access import refused_topics
from history.frames import frame_file
from history.incidents import incident_open, incident_release, incident_thumbnail
from history.mcapexport import incident_mcap, topics_in
from history.models import CameraFrame, Incident
from robot import interface as ri
from robot.api.validation import body_object, reject_unknown

OBJECT = OpenApiTypes.OBJECT
T_PARAM = OpenApiParameter("t", float, description="The moment, in epoch seconds.")


def _hidden(request: Request) -> frozenset[str]:
    names = [ri.topic(key).name for key in (*replay.STATE_KEYS, "rosout")]
    return frozenset(refused_topics(request.user, names))


def _incident(incident_id: int) -> Incident:
    incident = Incident.objects.filter(pk=incident_id).first()
    if incident is None:
        raise Http404("no such incident")
    return incident


def _immutable_file(path: Path, content_type: str) -> FileResponse:
    response = FileResponse(path.open("rb"), content_type=content_type)
    response["Cache-Control"] = "private, max-age=86400, immutable"
    return response


def _time(request: Request, name: str) -> float:
    value = replay.parse_time(request.query_params.get(name))
    if value is None:
        raise exceptions.ValidationError({name: "a moment in epoch seconds"})
    return value


@extend_schema(parameters=[T_PARAM], responses={200: OBJECT},
               summary="The robot as it was at a moment: state, map, pose, log, commands, frame")
@api_view(["GET"])
def state_view(request: Request) -> Response:
    return Response(replay.state_at(_time(request, "t"), hidden=_hidden(request)))


@extend_schema(parameters=[OpenApiParameter("start", float), OpenApiParameter("end", float)],
               responses={200: OBJECT},
               summary="Every change in (start, end] (at most 5 minutes), for a replay to play through")
@api_view(["GET"])
def window_view(request: Request) -> Response:
    start, end = _time(request, "start"), _time(request, "end")
    if end <= start:
        raise exceptions.ValidationError({"end": "after start"})
    return Response(replay.window(start, end, hidden=_hidden(request)))


@extend_schema(responses={200: OBJECT}, summary="The first and last recorded moment")
@api_view(["GET"])
def span_view(request: Request) -> Response:
    return Response(replay.span())


@extend_schema(summary="A recorded camera frame (JPEG)", responses={(200, "image/jpeg"): bytes})
@api_view(["GET"])
def frame_view(request: Request, frame_id: int) -> FileResponse:
    frame = CameraFrame.objects.filter(pk=frame_id).first()
    if frame is None or not frame_file(frame).is_file():
        raise Http404("no such frame")
    response = _immutable_file(frame_file(frame), "image/jpeg")
    response["X-Frame-Time"] = f"{frame.t:.3f}"
    return response


@extend_schema(summary="A recorded map as an image", responses={(200, "image/png"): bytes})
@api_view(["GET"])
def map_view(request: Request, sample_id: int) -> FileResponse:
    try:
        path = replay.map_png(sample_id)
    except Exception:
        raise Http404("no such map") from None
    return _immutable_file(path, "image/png")


def incident_out(incident: Incident) -> dict[str, Any]:
    thumb = incident_thumbnail(incident)
    return {
        **model_to_dict(incident), "kind_label": incident.get_kind_display(),  # every field but the row's creation
        "thumbnail": replay.frame_url(thumb.pk) if thumb else None,
        "replay": f"{reverse('history:replay')}?incident={incident.pk}",
        "mcap": reverse("history-incident-mcap", args=[incident.pk]),
    }


@extend_schema(request=OBJECT, responses={200: OBJECT, 201: OBJECT},
               summary="Incidents, newest first (GET); mark this moment (POST, operators; body {note})")
@api_view(["GET", "POST"])
def incidents_view(request: Request) -> Response:
    if request.method == "POST":
        if not is_operator(request.user):
            raise exceptions.PermissionDenied("Only operators may mark a moment.")
        body = body_object(request)
        reject_unknown(body, ["note"])
        note = clean_text(body.get("note", ""), field="note", limit=300, allow_empty=True) or "marked moment"
        incident = incident_open(kind=Incident.Kind.MANUAL, t=time.time(), summary=note,
                                 by=request.user.get_username())
        return Response(incident_out(incident), status=status.HTTP_201_CREATED)
    return Response({"incidents": [incident_out(i) for i in Incident.objects.all()[:200]]})


@extend_schema(request=None, responses={200: OBJECT}, summary="Let retention have an incident (admins)")
@api_view(["POST"])
def release_view(request: Request, incident_id: int) -> Response:
    if not is_admin(request.user):
        raise exceptions.PermissionDenied("Only admins may release an incident.")
    incident = _incident(incident_id)
    return Response(incident_out(incident_release(incident=incident, by=request.user.get_username())))


@extend_schema(summary="An incident as one MCAP file (camera as foxglove.CompressedImage, pose, every topic)",
               responses={(200, "application/octet-stream"): bytes})
@api_view(["GET"])
def mcap_view(request: Request, incident_id: int) -> HttpResponse:
    incident = _incident(incident_id)
    hidden = frozenset(refused_topics(request.user, topics_in(incident.start, incident.end)))
    data = incident_mcap(incident, hidden=hidden)
    response = HttpResponse(data, content_type="application/octet-stream")
    response["Content-Disposition"] = f'attachment; filename="incident-{incident.pk}-{incident.kind}.mcap"'
    return response
