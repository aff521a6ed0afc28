"""The camera recorder and the black box against the simulator: low-rate frames for replay, and an
E-STOP that keeps the seconds before it at full rate, camera included; retention spares what an
incident holds until an admin releases it."""

from __future__ import annotations

import asyncio
import time

import pytest
from asgiref.sync import sync_to_async

from history import blackbox, camerarec
from history.blackbox import BlackBox
from history.camerarec import CameraRecorder
from history.frames import frame_at, frame_file, prune_frames, write_frames
from history.incidents import Triggers, incident_open, incident_release
from history.models import CameraFrame, Incident, Mode, Sample, TopicPolicy
from history.policies import policy_upsert
from history.retention import prune_expired
from history.storage import utc, write_rows
from robot import interface as ri
from robot.live.announce import aannounce, server_update
from robot.live.keys import LATCH_KEY
from robot.live.latchstate import Latch
from robot.supervisor import running
from tests.helpers import async_wait_until

pytestmark = pytest.mark.postgres  # the history store: its writes, queries and rollups differ by engine

JPEG = b"\xff\xd8\xff\xe0fake-jpeg\xff\xd9"


async def _record_hourly(key: str) -> None:
    """A topic recorded every hour: an incident keeps every message of it."""
    topic = ri.topic(key)
    await sync_to_async(policy_upsert)(topic=topic.name, msg_type=topic.type, mode=Mode.PERIODIC, interval_s=3600)


@pytest.fixture
def camera_dir(settings, tmp_path):
    settings.CAMERA_RECORD_DIR = tmp_path / "camera"
    return settings.CAMERA_RECORD_DIR


@pytest.fixture
async def black_box(recording, sim, link, settings, camera_dir):
    """The recorder, the camera's pump and the black box on the test's loop, with a short window."""
    settings.VIDEO_URL = sim.video_url
    settings.CAMERA_RECORD_FPS = 2.0
    settings.INCIDENT_BEFORE_S = 3.0
    settings.INCIDENT_AFTER_S = 1.5
    await _record_hourly("robot_pose")
    tasks = [asyncio.ensure_future(camerarec.run_camera_recorder(link)),
             asyncio.ensure_future(blackbox.run_blackbox(link))]
    await async_wait_until(lambda: running(CameraRecorder) is not None and running(BlackBox) is not None, timeout=5)
    yield running(BlackBox)
    for task in tasks:
        task.cancel()
    await asyncio.gather(*tasks, return_exceptions=True)


def test_it_fires_on_the_edges_of_bumpers_diagnostics_and_error_lines():
    triggers = Triggers()
    bumper, rosout, diag = (ri.topic(k).name for k in ("bumper_state", "rosout", "diagnostics"))
    assert triggers.check(bumper, {"front_bumpers": [False], "rear_bumpers": [False]}) is None
    assert triggers.check(bumper, {"front_bumpers": [False, True], "rear_bumpers": []}) == (
        Incident.Kind.BUMPER, "front bumper pressed")
    assert triggers.check(bumper, {"front_bumpers": [True], "rear_bumpers": []}) is None  # still pressed
    assert triggers.check(rosout, {"level": 4, "name": "/n", "msg": "careful"}) is None
    assert triggers.check(rosout, {"level": 16, "name": "/n", "msg": "dead"}) == (
        Incident.Kind.LOG_ERROR, "FATAL /n: dead")
    error = {"status": [{"name": "motor", "level": 2, "message": "hot"}, {"name": "sonar", "level": 0}]}
    assert triggers.check(diag, error) == (Incident.Kind.DIAGNOSTICS, "motor: hot")
    assert triggers.check(diag, {"status": [{"name": "sonar", "level": 0}]}) is None  # motor not reported
    assert triggers.check(diag, error) is None  # motor still in ERROR
    assert triggers.check(diag, {"status": [{"name": "motor", "level": 0}]}) is None
    assert triggers.check(diag, error) is not None  # back into ERROR


def test_an_incident_absorbs_later_triggers_of_its_kind_within_its_window(db, settings):
    first = incident_open(kind=Incident.Kind.LOG_ERROR, t=1000.0, summary="a")
    again = incident_open(kind=Incident.Kind.LOG_ERROR, t=1010.0, summary="b")
    other = incident_open(kind=Incident.Kind.BUMPER, t=1010.0)
    later = incident_open(kind=Incident.Kind.LOG_ERROR, t=1000.0 + settings.INCIDENT_AFTER_S + 1)
    assert again.pk == first.pk and [tr["summary"] for tr in again.triggers] == ["b"]
    assert len({first.pk, other.pk, later.pk}) == 3
    assert (first.start, first.end) == (1000.0 - settings.INCIDENT_BEFORE_S, 1000.0 + settings.INCIDENT_AFTER_S)


def test_retention_spares_what_a_held_incident_keeps_until_it_is_released(db, camera_dir):
    now = time.time()
    old = now - 10 * 86400
    TopicPolicy.objects.create(topic="/p", msg_type="std_msgs/Int32", mode=Mode.EVERY, retention_s=86400)
    write_rows([("/p", "std_msgs/Int32", old + i, f'{{"data": {i}}}') for i in range(200)])
    write_frames([(old + i, JPEG, None) for i in range(0, 200, 10)])
    incident = incident_open(kind=Incident.Kind.MANUAL, t=old + 100)  # keeps old+40 .. old+130

    prune_expired(now=now)

    kept = sorted(Sample.objects.filter(topic="/p").values_list("data__data", flat=True))
    assert kept == list(range(40, 131))
    frames = list(CameraFrame.objects.values_list("t", flat=True))
    assert sorted(round(t - old) for t in frames) == [40, 50, 60, 70, 80, 90, 100, 110, 120, 130]
    assert all(frame_file(f).is_file() for f in CameraFrame.objects.all())

    incident_release(incident=incident, by="ada")
    prune_expired(now=now)
    assert not Sample.objects.filter(topic="/p").exists()
    assert not CameraFrame.objects.exists()
    assert not any(camera_dir.rglob("*.jpg"))


def test_frames_are_files_indexed_by_time(db, camera_dir):
    write_frames([(5000.0, JPEG, None), (5000.5, JPEG + b"2", None)])
    assert frame_at(5000.7).t == 5000.5
    assert frame_at(5000.2).t == 5000.0
    assert frame_at(4999.0) is None and frame_at(5010.0) is None
    assert frame_file(frame_at(5000.7)).read_bytes() == JPEG + b"2"
    assert prune_frames(now=5000.0 + 120, retention_s=60) == 2


@pytest.mark.django_db(transaction=True)
async def test_an_estop_keeps_the_seconds_before_it_at_full_rate_camera_included(black_box, recording, link,
                                                                                   settings):
    camera = running(CameraRecorder)
    pose = ri.topic("robot_pose").name
    await async_wait_until(lambda: camera.received >= 30, timeout=15, what="4 s of camera frames")
    # What the camera sent in the seconds the incident reaches back over (fewer on a busy machine).
    sent_from, counted_at = camera.received, time.time()
    await asyncio.sleep(settings.INCIDENT_BEFORE_S - 0.5)
    pressed, sent = time.time(), camera.received - sent_from
    latch = Latch(latched=True, by="olga", at=pressed).as_msg()
    await aannounce(LATCH_KEY, dict(server_update(LATCH_KEY, latch)), store=link.store)

    def captured():
        incident = Incident.objects.filter(kind=Incident.Kind.ESTOP).first()
        return incident if incident is not None and incident.complete else None

    deadline = time.monotonic() + 15
    while (incident := await sync_to_async(captured)()) is None:
        assert time.monotonic() < deadline, "no complete E-STOP incident"
        await asyncio.sleep(0.1)
    await asyncio.sleep(2 * settings.HISTORY_FLUSH_S + 0.3)

    assert incident.by == "olga" and incident.t == pytest.approx(pressed)
    # The incident's own frames and those replay's 2 fps had kept already (retention spares both).
    frames = await sync_to_async(lambda: list(CameraFrame.objects.filter(
        t__gte=incident.start, t__lte=incident.end).values_list("t", flat=True)))()
    assert await sync_to_async(CameraFrame.objects.filter(incident=incident).exists)()
    before = [t for t in frames if t < pressed]
    # The seconds before are there at the camera's full rate (~8 frames a second), not at replay's 2 fps:
    # every frame it sent then is kept.
    counted = [t for t in before if t >= counted_at]
    assert sent > settings.CAMERA_RECORD_FPS * (pressed - counted_at) + 1, f"the camera sent only {sent} frames"
    assert len(counted) >= sent - 1, (len(counted), sent)
    assert min(before) - incident.start < 1.0
    poses = await sync_to_async(lambda: list(Sample.objects.filter(
        topic=pose, received_at__gte=utc(incident.start), received_at__lte=utc(incident.end))
        .values_list("received_at", flat=True)))()
    stamps = sorted(at.timestamp() for at in poses)
    # Both ends within a second, as the frames: a loaded machine can hold the 10 Hz pose back that long.
    assert stamps and stamps[0] - incident.start < 1.0 and incident.end - stamps[-1] < 1.0
    assert len([t for t in stamps if t < pressed]) >= 20  # the simulator's pose at 10 Hz
    assert recording.dropped == 0 and camera.lost == 0


@pytest.mark.django_db(transaction=True)
async def test_a_marked_moment_from_another_process_is_captured_across_a_restart(recording, sim, link, settings):
    settings.INCIDENT_BEFORE_S = 2.0
    settings.INCIDENT_AFTER_S = 3.0
    odom = ri.topic("odom").name
    await _record_hourly("odom")
    first = asyncio.ensure_future(blackbox.run_blackbox(link))
    await async_wait_until(lambda: running(BlackBox) is not None and recording.received > 30, timeout=10,
                           what="the recorder hearing the robot")
    await asyncio.sleep(settings.INCIDENT_BEFORE_S + 0.5)  # its ring holds the seconds before the mark
    # A web process marks the moment: only the database tells the black box.
    incident = await sync_to_async(incident_open)(kind=Incident.Kind.MANUAL, t=time.time(), by="otto")
    await asyncio.sleep(1.5)
    # The link's process hands over (a deploy, a failover) in the middle of the window: the next one
    # starts hearing the robot as the old one stops and writes what it took.
    first.cancel()
    second = asyncio.ensure_future(blackbox.run_blackbox(link))
    await asyncio.gather(first, return_exceptions=True)
    try:
        await asyncio.sleep(incident.end - time.time() + 1.5)
    finally:
        second.cancel()
        await asyncio.gather(second, return_exceptions=True)

    kept = Sample.objects.filter(topic=odom, received_at__gte=utc(incident.start), received_at__lte=utc(incident.end))
    seqs = await sync_to_async(lambda: sorted(d["header"]["seq"] for d in kept.values_list("data", flat=True)))()
    # The minute before and what came after the restart are there, every message numbered in between too:
    # what the first black box took it wrote on stopping, and the second one picked the incident up.
    # (Both hear the robot for a moment at the handover: a loaded machine can store a message of that
    # moment twice, never lose one.)
    unique = sorted(set(seqs))
    assert len(unique) >= 30 and unique == list(range(unique[0], unique[-1] + 1))
    assert len(seqs) - len(unique) <= 2, seqs
    stamps = await sync_to_async(lambda: sorted(a.timestamp() for a in kept.values_list("received_at", flat=True)))()
    assert stamps[0] - incident.start < 0.5 and incident.end - stamps[-1] < 0.5


@pytest.mark.django_db(transaction=True)
async def test_an_incident_leaves_topics_the_admin_does_not_record_unrecorded(black_box, recording, link):
    odom = ri.topic("odom").name  # no policy: not recorded
    await async_wait_until(lambda: recording.received > 30, timeout=10, what="the recorder hearing the robot")
    incident = await sync_to_async(incident_open)(kind=Incident.Kind.MANUAL, t=time.time())
    await async_wait_until(lambda: incident.pk in recording.windows, timeout=5, what="the incident adopted")
    pose = ri.topic("robot_pose").name
    in_window = Sample.objects.filter(topic=pose, received_at__gte=utc(incident.start))
    # The pose (recorded hourly: one sample at most otherwise) at full rate.
    deadline = time.monotonic() + 10
    while await sync_to_async(in_window.count)() <= 5:
        assert time.monotonic() < deadline, "the pose was not kept at full rate in the incident"
        await asyncio.sleep(0.1)
    assert not await sync_to_async(Sample.objects.filter(topic=odom).exists)()
