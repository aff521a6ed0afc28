"""The camera through the server: frames for logged-in users, nobody else, and a clear
503 placeholder while the video server is down."""

import asyncio

import pytest
from asgiref.testing import ApplicationCommunicator
from django.test import Client

from tests.helpers import async_wait_until

pytestmark = pytest.mark.django_db(transaction=True)
BOUNDARY = b"--boundarydonotcross"


@pytest.fixture
def video(sim, settings):
    settings.VIDEO_URL = sim.video_url
    return sim


def session_cookie(user) -> bytes:
    client = Client()
    client.force_login(user)
    return f"sessionid={client.cookies['sessionid'].value}".encode()


def http_scope(path: str, cookie: bytes | None = None, query: bytes = b"") -> dict:
    headers = [(b"host", b"127.0.0.1")] + ([(b"cookie", cookie)] if cookie else [])
    return {"type": "http", "asgi": {"version": "3.0"}, "http_version": "1.1", "method": "GET", "scheme": "http",
            "path": path, "raw_path": path.encode(), "query_string": query, "headers": headers,
            "client": ("127.0.0.1", 50000), "server": ("127.0.0.1", 8000)}


async def open_stream(path: str, cookie: bytes | None = None) -> tuple[ApplicationCommunicator, dict]:
    from server.asgi import application

    app = ApplicationCommunicator(application, http_scope(path, cookie))
    await app.send_input({"type": "http.request", "body": b"", "more_body": False})
    start = await app.receive_output(timeout=10)
    assert start["type"] == "http.response.start"
    return app, start


async def test_it_streams_camera_frames_to_a_logged_in_user_and_lets_go_of_the_upstream(video, viewer):
    cookie = await asyncio.to_thread(session_cookie, viewer)
    app, start = await open_stream("/video/stream", cookie)
    assert start["status"] == 200
    headers = dict(start["headers"])
    assert headers[b"Content-Type"].startswith(b"multipart/x-mixed-replace")
    body = b""
    while body.count(b"\xff\xd8") < 2:  # two JPEG frames (start-of-image markers)
        message = await app.receive_output(timeout=5)
        assert message["type"] == "http.response.body" and message.get("more_body")
        body += message["body"]
    assert body.count(BOUNDARY) >= 2
    assert str(video.video_port).encode() not in body  # the upstream address never reaches the browser

    await app.send_input({"type": "http.disconnect"})
    await app.wait(timeout=5)
    await async_wait_until(lambda: not video.call(lambda: video.robot.video.writers), timeout=5,
                           what="the upstream stream closed")


async def test_it_sends_a_snapshot_jpeg(video, operator):
    cookie = await asyncio.to_thread(session_cookie, operator)
    app, start = await open_stream("/video/snapshot", cookie)
    assert start["status"] == 200 and dict(start["headers"])[b"Content-Type"] == b"image/jpeg"
    body = b""
    while True:
        message = await app.receive_output(timeout=5)
        body += message.get("body", b"")
        if not message.get("more_body"):
            break
    assert body.startswith(b"\xff\xd8") and body.endswith(b"\xff\xd9")


@pytest.mark.parametrize("path", ["/video/stream", "/video/snapshot"])
async def test_it_refuses_anonymous_users(video, path):
    _app, start = await open_stream(path)
    assert start["status"] == 302
    assert dict(start["headers"])[b"Location"].startswith(b"/accounts/login/")
    assert not video.call(lambda: video.robot.video.writers)


@pytest.mark.parametrize("path", ["/video/stream", "/video/snapshot"])
def test_it_answers_503_with_a_placeholder_while_the_video_server_is_down(client, viewer, settings, path):
    from tests.stack import free_port

    settings.VIDEO_URL = f"http://127.0.0.1:{free_port()}"
    client.force_login(viewer)
    response = client.get(path)
    assert response.status_code == 503
    assert response["Content-Type"] == "image/svg+xml" and response["Retry-After"]
    assert b"Camera unavailable" in response.content


def upstream_streams(video) -> int:
    return video.call(lambda: len(video.robot.video.writers))


async def read_frames(app: ApplicationCommunicator, count: int) -> bytes:
    body = b""
    while body.count(b"\xff\xd8") < count:
        message = await app.receive_output(timeout=5)
        assert message["type"] == "http.response.body" and message.get("more_body")
        body += message["body"]
    return body


async def test_many_viewers_share_one_upstream_stream_closed_after_the_last_leaves(video, viewer, operator):
    cookies = [await asyncio.to_thread(session_cookie, user) for user in (viewer, operator, viewer)]
    viewers = [await open_stream("/video/stream", cookie) for cookie in cookies]
    for app, start in viewers:
        assert start["status"] == 200
        await read_frames(app, 2)
    assert upstream_streams(video) == 1

    other_size, _ = await open_stream_with_query("/video/stream", cookies[0], b"width=320&height=240")
    await read_frames(other_size, 1)
    assert upstream_streams(video) == 2  # another size is another upstream stream
    await other_size.send_input({"type": "http.disconnect"})
    await other_size.wait(timeout=5)

    for app, _ in viewers[:-1]:
        await app.send_input({"type": "http.disconnect"})
        await app.wait(timeout=5)
    await async_wait_until(lambda: upstream_streams(video) == 1, timeout=5, what="only the shared stream left")
    last, _ = viewers[-1]
    await read_frames(last, 2)  # the remaining viewer still gets new frames
    await last.send_input({"type": "http.disconnect"})
    await last.wait(timeout=5)
    await async_wait_until(lambda: upstream_streams(video) == 0, timeout=5, what="the upstream stream closed")


async def test_sizes_are_snapped_to_a_short_list_so_many_sizes_open_few_streams_on_the_robot(video, viewer,
                                                                                              settings):
    """30 distinct widths once opened 30 MJPEG streams on the robot's video server."""
    settings.CAMERA_STREAMS_PER_PERSON = 100
    cookie = await asyncio.to_thread(session_cookie, viewer)
    apps = []
    for width in range(100, 2000, 63):  # 31 widths
        app, _ = await open_stream_with_query("/video/stream", cookie, f"width={width}&quality={width % 97}".encode())
        await read_frames(app, 1)
        apps.append(app)
    from dashboard.videorelay import MAX_UPSTREAMS, get_relay

    assert upstream_streams(video) <= MAX_UPSTREAMS + 1  # a few sizes, then the camera's own
    sizes = [dict(key) for key in get_relay().upstreams]
    assert {s["width"] for s in sizes if "width" in s} <= {"320", "640", "1280"}
    assert {s["quality"] for s in sizes if "quality" in s} <= {"30", "50", "80"}
    for app in apps:
        await app.send_input({"type": "http.disconnect"})
        await app.wait(timeout=5)
    await async_wait_until(lambda: upstream_streams(video) == 0, timeout=5, what="every upstream stream closed")


async def test_streams_are_capped_per_person_and_in_all(video, viewer, operator, settings):
    settings.CAMERA_STREAMS_PER_PERSON, settings.CAMERA_STREAMS_TOTAL = 2, 3
    mine, theirs = [await asyncio.to_thread(session_cookie, user) for user in (viewer, operator)]
    apps = [(await open_stream("/video/stream", mine))[0] for _ in range(2)]
    refused, start = await open_stream("/video/stream", mine)
    assert start["status"] == 429
    body = (await refused.receive_output(timeout=5))["body"]
    assert b"Too many camera streams" in body
    app, start = await open_stream("/video/stream", theirs)  # someone else still may
    assert start["status"] == 200
    apps.append(app)
    _, start = await open_stream("/video/stream", theirs)  # but not past the server's number
    assert start["status"] == 429
    for app in apps:
        await app.send_input({"type": "http.disconnect"})
        await app.wait(timeout=5)


@pytest.mark.parametrize("change", ["deactivated", "logged out"])
async def test_a_persons_streams_end_within_a_second_of_their_access_ending(video, viewer, change):
    client = Client()
    await asyncio.to_thread(client.force_login, viewer)
    cookie = f"sessionid={client.cookies['sessionid'].value}".encode()
    app, start = await open_stream("/video/stream", cookie)
    assert start["status"] == 200
    await read_frames(app, 1)

    def revoke() -> None:
        if change == "deactivated":
            viewer.is_active = False
            viewer.save()
        else:
            client.post("/accounts/logout/")

    await asyncio.to_thread(revoke)
    async with asyncio.timeout(1.0):
        while (await app.receive_output(timeout=1)).get("more_body"):
            pass
    await async_wait_until(lambda: upstream_streams(video) == 0, timeout=5, what="the upstream stream closed")


async def open_stream_with_query(path: str, cookie: bytes, query: bytes) -> tuple[ApplicationCommunicator, dict]:
    from server.asgi import application

    app = ApplicationCommunicator(application, http_scope(path, cookie, query))
    await app.send_input({"type": "http.request", "body": b"", "more_body": False})
    start = await app.receive_output(timeout=10)
    assert start["status"] == 200
    return app, start


def stamp(part: bytes) -> float:
    head = part.split(b"\r\n\r\n", 1)[0].decode()
    return float(next(line.split(":", 1)[1] for line in head.split("\r\n") if line.startswith("X-Timestamp")))


async def test_a_slow_viewer_skips_to_the_newest_frame_without_delaying_others(video):
    from dashboard.videorelay import VideoRelay

    relay = VideoRelay()
    params = {"topic": "/videostream", "type": "mjpeg"}
    fast, slow = await relay.join(video.video_url, params), await relay.join(video.video_url, params)
    seen: list[float] = []
    for _ in range(6):  # the slow viewer reads nothing meanwhile
        part = await asyncio.wait_for(fast.next(), 5)
        assert part is not None
        seen.append(stamp(part))
    part = await asyncio.wait_for(slow.next(), 1)
    assert part is not None and stamp(part) >= seen[-1]  # the newest, not the oldest unread
    assert slow.frame is None and not slow.ready.is_set()  # nothing else queued behind it
    assert seen == sorted(seen) and len(set(seen)) == 6
    assert upstream_streams(video) == 1
    relay.leave(fast)
    relay.leave(slow)
    await async_wait_until(lambda: upstream_streams(video) == 0, timeout=5, what="the upstream stream closed")


async def test_viewers_are_told_when_the_upstream_goes_away(video):
    from dashboard.videorelay import VideoRelay

    relay = VideoRelay()
    viewer = await relay.join(video.video_url, {"topic": "/videostream", "type": "mjpeg"})
    assert await asyncio.wait_for(viewer.next(), 5) is not None
    video.call(lambda: [w.transport.abort() for w in video.robot.video.writers])
    while (part := await asyncio.wait_for(viewer.next(), 5)) is not None:
        assert part.startswith(b"--")
    relay.leave(viewer)
    assert not relay.upstreams
