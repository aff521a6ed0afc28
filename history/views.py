from django.http import HttpRequest, HttpResponse
from django.urls import reverse

from cyborg_site.rendering import render_safe
from cyborg_site.roles import is_admin, is_operator
from history.models import Incident
from history.plotunits import units_of
from history.replay import replay_start
from history.replay_api import incident_out
from history.selectors import recorded_topics
from robot import interface as ri


def index(request: HttpRequest) -> HttpResponse:
    """The plots page: pick a topic, a numeric field and a time range; presets for the usual views."""
    emotion = ri.topic("emotional_state").name
    config = {
        "topics": [
            {"topic": t["topic"], "msg_type": t["msg_type"], "fields": t["fields"], "text": t["text"],
             "units": units_of(t["topic"], t["fields"])}
            for t in recorded_topics()
        ],
        "presets": {
            "battery": {"topic": ri.topic("battery_soc").name, "fields": ["data"], "scale": 100, "unit": "%",
                        "range": "day", "label": "Battery over the last day"},
            "pad": {"topic": emotion, "fields": ["current_pleasure", "current_arousal", "current_dominance"],
                    "scale": 1, "unit": "", "range": "day", "label": "Emotion (PAD) over time"},
        },
        "state_topic": ri.topic("state_change").name,
        "urls": {name: reverse(f"history-{name}") for name in ("samples", "timeline", "messages", "export")},
    }
    context = {"history_config": config, "can_edit_policies": is_admin(request.user)}
    return render_safe(request, "history/index.html", context)


def replay_page(request: HttpRequest) -> HttpResponse:
    """The robot as it was: pick a range, an incident or an audit row; a scrubber drives the page."""
    config = replay_start(request.GET.get("incident"), request.GET.get("audit"), request.GET.get("t"),
                          request.GET.get("start"), request.GET.get("end"))
    config["urls"] = {"state": reverse("history-replay-state"), "window": reverse("history-replay-window"),
                      "incidents": reverse("history-incidents")}
    config["incidents"] = [{"id": i.pk, "label": f"{i.get_kind_display()} · {i.summary}"[:120], "t": i.t}
                           for i in Incident.objects.all()[:50]]
    return render_safe(request, "history/replay.html", {"replay_config": config})


def incidents_page(request: HttpRequest) -> HttpResponse:
    """Incidents, newest first, each with its thumbnail, who drove, a link into replay and its MCAP."""
    incidents = [incident_out(i) for i in Incident.objects.all()[:200]]
    return render_safe(request, "history/incidents.html", {
        "incidents": incidents, "can_release": is_admin(request.user), "can_mark": is_operator(request.user),
        "urls": {"incidents": reverse("history-incidents")},
    })
