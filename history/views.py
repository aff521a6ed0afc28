from django.http import HttpRequest, HttpResponse
from django.urls import reverse

from cyborg_site.rendering import render_safe
from cyborg_site.roles import is_admin
from history.selectors import recorded_topics
from robot import interface as ri


def index(request: HttpRequest) -> HttpResponse:
    """The plots page: pick a topic, a numeric field and a time range; presets for the usual views."""
    emotion = ri.topic("emotional_state").name
    config = {
        "topics": [
            {"topic": t["topic"], "msg_type": t["msg_type"], "fields": t["fields"], "text": t["text"]}
            for t in recorded_topics()
        ],
        "presets": {
            "battery": {"topic": ri.topic("battery_soc").name, "fields": ["data"], "scale": 100, "unit": "%",
                        "range": "day", "label": "Battery over the last day"},
            "pad": {"topic": emotion, "fields": ["current_pleasure", "current_arousal", "current_dominance"],
                    "scale": 1, "unit": "", "range": "day", "label": "Emotion (PAD) over time"},
        },
        "state_topic": ri.topic("state_change").name,
        "urls": {
            "samples": reverse("history-samples"),
            "timeline": reverse("history-timeline"),
            "messages": reverse("history-messages"),
            "export": reverse("history-export"),
        },
    }
    context = {"history_config": config, "can_edit_policies": is_admin(request.user)}
    return render_safe(request, "history/index.html", context)
