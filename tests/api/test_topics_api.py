"""The topics API: every role lists the robot's topics and measures a rate; bad names are refused
before anything reaches the robot; recording a topic is for admins only."""

from django.urls import reverse

from history.models import TopicPolicy
from robot import interface as ri

ROSOUT = ri.topic("rosout").name


def test_a_viewer_lists_and_searches_the_robots_topics(viewer_api, link_thread):
    answer = viewer_api.get(reverse("api-topics"))
    assert answer.status_code == 200, answer.json()
    topics = {t["name"]: t for t in answer.json()["topics"]}
    assert topics[ROSOUT]["type"] == "rosgraph_msgs/Log" and topics[ROSOUT]["publishers"]
    found = viewer_api.get(reverse("api-topics"), {"q": "LOG"}).json()["topics"]
    assert [t["type"] for t in found] == ["rosgraph_msgs/Log"] * len(found) and found


def test_a_viewer_measures_a_rate_and_bad_requests_get_clear_errors(viewer_api, link_thread, sim):
    url = reverse("api-topics-rate")
    answer = viewer_api.get(url, {"topic": ri.topic("robot_pose").name, "window_s": 1})
    assert answer.status_code == 200, answer.json()
    assert answer.json()["hz"] > 0
    bad = viewer_api.get(url, {"topic": "not a topic"})
    assert bad.status_code == 400 and bad.json()["field"] == "topic"
    too_long = viewer_api.get(url, {"topic": ROSOUT, "window_s": 100})
    assert too_long.status_code == 400 and too_long.json()["field"] == "window_s"
    missing = viewer_api.get(url, {"topic": "/no/such_topic", "window_s": 0.5})
    assert missing.status_code == 404 and missing.json()["code"] == "not_found"
    assert "/no/such_topic" in missing.json()["detail"]
    assert sim.subscription_count("/no/such_topic") == 0


def test_only_admins_may_record_a_topic(viewer_api, operator_api, admin_api):
    body = {"topics": [{"topic": "/RosAria/sonar", "msg_type": "sensor_msgs/PointCloud", "mode": "every"}]}
    for refused in (viewer_api, operator_api):
        assert refused.patch(reverse("history-topics"), body, format="json").status_code == 403
    assert not TopicPolicy.objects.filter(topic="/RosAria/sonar").exists()
    assert admin_api.patch(reverse("history-topics"), body, format="json").status_code == 200
    assert TopicPolicy.objects.get(topic="/RosAria/sonar").mode == "every"
