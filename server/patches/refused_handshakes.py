"""A websocket handshake that autobahn refuses itself ends quietly.

Autobahn reads the Host and Origin headers before Daphne's ``onConnect`` runs and answers a
malformed one (``Host: [``, ``Origin: http://[``, a port that is no number) with a 400 itself.
Closing that connection calls Daphne's ``onClose``, which uses what only ``onConnect`` sets
(``self.server``): an AttributeError that Twisted logs (through roslibpy's observer, to Python
logging) as a CRITICAL "Unhandled Error" with a 30-line traceback, for anyone who sends such a
header. Such a connection never reached Daphne's bookkeeping or the application, so there is
nothing to close; autobahn's one warning line says why it was refused. (Daphne 4.2.3, checked by
tests/site/test_refused_handshakes.py.)
"""

from __future__ import annotations

from typing import Any

from daphne.ws_protocol import WebSocketProtocol

daphne_on_close = WebSocketProtocol.onClose


def on_close_after_connect(self: Any, was_clean: bool, code: int | None, reason: str | None) -> None:
    if not hasattr(self, "server"):  # refused by autobahn before Daphne's onConnect
        return
    daphne_on_close(self, was_clean, code, reason)


def install() -> None:
    WebSocketProtocol.onClose = on_close_after_connect
