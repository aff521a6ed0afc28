"""roslibpy, with large frames decoded on a worker thread instead of the reactor's.

roslibpy decodes every frame with ``json.loads`` where it arrives: on the reactor thread,
which inside Daphne is the web server's event loop. A 4000 x 4000 map would stall every
page and websocket for most of a second. ``LinkRos`` is ``roslibpy.Ros`` with a protocol
that sends frames of ``LARGE_FRAME_BYTES`` and more to one decoding thread (so they stay
in order) and hands the decoded message back to roslibpy's own dispatch on the reactor.
It also turns Nagle off on the rosbridge socket (see ``tcpNoDelay``), replaces lone UTF-16
surrogates in the robot's text (they break every UTF-8 encoder downstream) with U+FFFD, and
checks a wss:// robot's certificate, which autobahn's default TLS context never does.
"""

from __future__ import annotations

import asyncio
import json
import logging
import re
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import roslibpy
from autobahn.twisted.websocket import connectWS
from django.conf import settings
from roslibpy.comm.comm_autobahn import AutobahnRosBridgeProtocol
from roslibpy.core import Message
from twisted.internet import ssl
from twisted.python import threadable

from cyborg_site.text import scrub_json
from robot.link.wire import LARGE_FRAME_BYTES, decode_frame, may_hold_surrogates
from robot.live.groups import LinkReply

log = logging.getLogger(__name__)

_decoder = ThreadPoolExecutor(max_workers=1, thread_name_prefix="rosbridge-decode")


class LinkProtocol(AutobahnRosBridgeProtocol):
    # autobahn applies ``tcpNoDelay`` in connectionMade *before* copying the factory's options
    # onto the protocol, so the instance value is still unset there and Nagle stays on: small
    # frames then wait ~30-40 ms for the robot's delayed ACK. A class default is read in time.
    tcpNoDelay = True
    _began = 0.0

    def send_message(self, payload: bytes) -> None:
        # roslibpy hands every send to the reactor with callFromThread: a wake-up and a loop turn
        # even from the reactor's own thread, where the link publishes. There, send at once.
        if threadable.isInIOThread():
            self.sendMessage(payload, isBinary=False, fragmentSize=None, sync=False, doNotCompress=False)
        else:
            super().send_message(payload)

    def onMessageBegin(self, isBinary: bool) -> None:
        self._began = time.perf_counter()
        super().onMessageBegin(isBinary)

    def on_message(self, payload: bytes) -> None:
        if len(payload) < LARGE_FRAME_BYTES:
            if may_hold_surrogates(payload):
                self._dispatch(Message(scrub_json(json.loads(payload))))
            else:
                super().on_message(payload)
        else:
            log.info("received a %.1f MB frame in %.0f ms; decoding it off the event loop",
                     len(payload) / 1e6, (time.perf_counter() - self._began) * 1000)
            _decoder.submit(self._decode_large, payload, getattr(self.factory, "array_topics", frozenset()))

    def _decode_large(self, payload: bytes, array_topics: frozenset[str]) -> None:
        try:
            frame = decode_frame(payload, array_topics=array_topics)
            message = Message(scrub_json(frame) if may_hold_surrogates(payload) else frame)
        except ValueError:
            log.exception("dropped an undecodable %d-byte frame from rosbridge", len(payload))
            return
        from twisted.internet import reactor  # imported late: Daphne installs its own reactor first

        reactor.callFromThread(self._dispatch, message)

    def _dispatch(self, message: dict[str, Any]) -> None:
        handler = self._message_handlers.get(message.get("op"))
        if handler is None:
            log.warning("no handler for rosbridge operation %r", message.get("op"))
            return
        try:
            handler(message)
        except Exception:
            log.exception("handling a %r frame failed", message.get("op"))


_twisted_log_observer: Any = None


def _keep_one_twisted_log_observer(manager: Any) -> None:
    """roslibpy starts a Twisted-to-logging observer for every connection and never stops it, so
    after N connections (a link that restarts, a test suite) every Twisted line is logged N times."""
    global _twisted_log_observer
    observer = manager._log_observer
    if _twisted_log_observer is None:
        _twisted_log_observer = observer
    elif observer is not _twisted_log_observer:
        observer.stop()


def verified_tls(host: str) -> Any:
    """TLS options that check the robot's certificate and name against ``ROSBRIDGE_CA_FILE`` (PEM, one
    or more certificates) or, unset, the system's roots."""
    if not settings.ROSBRIDGE_CA_FILE:
        return ssl.optionsForClientTLS(host, trustRoot=ssl.platformTrust())
    pem = Path(settings.ROSBRIDGE_CA_FILE).read_text()
    certificates = re.findall(r"-----BEGIN CERTIFICATE-----.+?-----END CERTIFICATE-----", pem, re.S)
    return ssl.optionsForClientTLS(host, trustRoot=ssl.trustRootFromCertificates(
        [ssl.Certificate.loadPEM(c) for c in certificates]))


class LinkRos(roslibpy.Ros):
    """``roslibpy.Ros`` whose connections use ``LinkProtocol``; ``array_topics`` get numpy arrays."""

    def __init__(self, url: str, *, array_topics: frozenset[str] = frozenset()) -> None:
        self._array_topics = array_topics
        super().__init__(url, transport="twisted")
        _keep_one_twisted_log_observer(self.factory.manager)

    def connect(self) -> None:
        # Ros.__init__ connects at once: set the protocol before the first connection is built.
        self.factory.protocol = LinkProtocol
        self.factory.array_topics = self._array_topics
        if self.factory.isSecure:
            factory, tls = self.factory, verified_tls(self.factory.host)
            factory._connect = lambda: setattr(factory, "connector", connectWS(factory, tls))
        super().connect()


async def call_service(ros: roslibpy.Ros, name: str, service_type: str, args: dict[str, Any],
                       timeout: float) -> LinkReply:
    """Call a service over ``ros`` from the event loop without blocking it: the link's reply shape
    (``ok`` and ``values``, or ``error_code`` and ``error``)."""
    loop = asyncio.get_running_loop()
    future: asyncio.Future = loop.create_future()

    def settle(ok: bool, value: Any) -> None:
        if not future.done():
            future.set_result((ok, value))

    def from_reactor(ok: bool, value: Any) -> None:
        if not loop.is_closed():
            loop.call_soon_threadsafe(settle, ok, value)

    roslibpy.Service(ros, name, service_type).call(
        roslibpy.ServiceRequest(args),
        callback=lambda values: from_reactor(True, dict(values)),
        errback=lambda error: from_reactor(False, error),
    )
    try:
        ok, value = await asyncio.wait_for(future, timeout)
    except TimeoutError:
        return {"ok": False, "error_code": "timeout", "error": f"{name} did not answer in {timeout:g} s"}
    if ok:
        return {"ok": True, "values": value}
    return {"ok": False, "error_code": "failed", "error": str(value)}


class Publishers:
    """One advertised topic per name on a connection: roslibpy advertises it with the first publish."""

    def __init__(self) -> None:
        self._topics: dict[str, roslibpy.Topic] = {}

    def publish(self, ros: roslibpy.Ros, name: str, msg_type: str, msg: dict[str, Any]) -> None:
        topic = self._topics.get(name)
        if topic is None:
            topic = self._topics[name] = roslibpy.Topic(ros, name, msg_type, queue_size=10)
        topic.publish(Message(msg))


def close_quietly(ros: roslibpy.Ros) -> None:
    """Close a rosbridge connection (blocking: from a worker thread), whatever state it is in."""
    try:
        ros.close(timeout=2)
    except Exception:
        log.debug("close of the rosbridge connection did not complete", exc_info=True)
