"""The robot link's hooks into roslibpy's and Twisted's private parts are made for exact releases: the
link refuses others, and each part it uses has a canary here that fails when a release renames or
drops it (then the hook is checked, and the pins in robot/link/releases.py move with the lock)."""

from __future__ import annotations

import inspect
from types import SimpleNamespace

import pytest
import roslibpy
from django.core import checks
from django.core.management import call_command
from roslibpy.comm.comm import RosBridgeProtocol
from roslibpy.comm.comm_autobahn import AutobahnRosBridgeClientFactory, TwistedEventLoopManager
from twisted.internet.protocol import ReconnectingClientFactory
from twisted.internet.task import Clock
from twisted.python import log as twisted_log

from robot.link import hosting
from robot.link.releases import LINK_HOOKS
from robot.link.rosclient import LinkProtocol


def test_the_installed_releases_are_the_hooked_ones():
    assert LINK_HOOKS.others() == {}
    LINK_HOOKS.refuse_others()


def test_another_release_is_refused_by_the_checks_and_by_robotlink_before_it_starts(monkeypatch):
    monkeypatch.setitem(LINK_HOOKS.releases, "roslibpy", "1.0")
    assert [e.id for e in checks.run_checks() if e.id == "robot.E004"] == ["robot.E004"]
    monkeypatch.setattr("asyncio.run", lambda main: pytest.fail("the link started"))
    refused = r"roslibpy 2\.1\.0 is installed, but the robot link's hooks into roslibpy and Twisted are for 1\.0"
    with pytest.raises(RuntimeError, match=refused):
        call_command("robotlink")


def test_another_release_stops_daphne_before_it_starts_the_embedded_link(monkeypatch, settings):
    settings.EMBEDDED = settings.ROBOT_LINK_EMBEDDED = True
    reactor = SimpleNamespace(addSystemEventTrigger=lambda *args: None,
                              callWhenRunning=lambda *args: pytest.fail("the link was scheduled"))
    monkeypatch.setattr(hosting, "daphne_reactor", lambda: reactor)
    monkeypatch.setitem(LINK_HOOKS.releases, "twisted", "1.0")
    with pytest.raises(RuntimeError, match=r"twisted 26\.10\.0 is installed"):
        hosting.autostart_in_daphne(halt_drivers=lambda: pytest.fail("no driver to halt"))


def test_message_handlers_canary():
    """rosclient's LinkProtocol dispatches a message it decoded itself through ``_message_handlers``,
    overriding ``on_message``."""
    protocol = LinkProtocol()
    assert isinstance(protocol._message_handlers, dict)
    assert protocol._message_handlers["publish"] == protocol._handle_publish
    assert protocol._message_handlers["service_response"] == protocol._handle_service_response
    assert list(inspect.signature(RosBridgeProtocol.on_message).parameters) == ["self", "payload"]


def test_factory_connect_and_proto_canaries():
    """rosclient replaces the factory's ``_connect`` (a wss:// robot's certificate is checked); status and
    connection read ``_proto``, the open connection's protocol or None."""
    assert "self._connect" in inspect.getsource(AutobahnRosBridgeClientFactory.connect)
    assert "self.connector = connectWS(self)" in inspect.getsource(AutobahnRosBridgeClientFactory._connect)
    factory = AutobahnRosBridgeClientFactory("ws://127.0.0.1:9")
    assert factory._proto is None and factory.connector is None
    protocol = SimpleNamespace(_manual_disconnect=True)
    factory.ready(protocol)
    assert factory._proto is protocol
    factory.clientConnectionLost(None, None)
    assert factory._proto is None


def test_reconnect_call_id_canary():
    """status cancels the backoff's pending retry, ``_callID``, before ``resetDelay``, which forgets it
    without cancelling it."""
    factory = ReconnectingClientFactory()
    factory.clock = Clock()
    factory.retry(SimpleNamespace(connect=lambda: None))
    pending = factory._callID
    assert pending.active()
    factory.resetDelay()
    assert factory._callID is None and pending.active()


def test_log_observer_canary():
    """rosclient stops the Twisted-to-logging observer each new roslibpy manager starts, ``_log_observer``."""
    manager = TwistedEventLoopManager()
    observer = manager._log_observer
    try:
        assert isinstance(observer, twisted_log.PythonLoggingObserver)
        assert observer.emit in twisted_log.theLogPublisher.observers
    finally:
        observer.stop()
    assert observer.emit not in twisted_log.theLogPublisher.observers


def test_topic_connect_message_canary():
    """subscriptions sends a topic's ``_connect_message`` (its subscribe op) again on a new connection,
    and ``reconnect_on_close=False`` keeps roslibpy from sending it a second later itself."""
    sent: list[object] = []
    ros = SimpleNamespace(id_counter=7, on=lambda *args: sent.append(("on", args[0])),
                          send_on_ready=lambda message: sent.append(message))
    topic = roslibpy.Topic(ros, "/odom", "nav_msgs/Odometry", reconnect_on_close=False)
    topic.subscribe(lambda msg: None)
    assert topic._connect_message["op"] == "subscribe" and topic._connect_message["topic"] == "/odom"
    assert topic._connect_message in sent
    assert ("on", "close") not in sent  # no delayed subscribe of its own after a close
