"""One access log line per request: Daphne's. Twisted's own line (which roslibpy's log observer
would send to Python logging next to it) is not written."""

from daphne.http_protocol import HTTPFactory
from twisted.logger import globalLogPublisher
from twisted.web.test.requesthelper import DummyRequest


def test_twisted_writes_no_access_line_of_its_own():
    import server.asgi  # noqa: F401  (the web server's set-up)

    events: list[dict] = []
    globalLogPublisher.addObserver(events.append)
    factory = HTTPFactory(server=None)
    factory.startFactory()
    try:
        request = DummyRequest([b""])
        request.code, request.sentLength, request.clientproto = 200, 10, b"HTTP/1.1"
        factory.log(request)
    finally:
        factory.stopFactory()
        globalLogPublisher.removeObserver(events.append)
    assert [e for e in events if "HTTP/1.1" in str(e.get("log_io", ""))] == []
