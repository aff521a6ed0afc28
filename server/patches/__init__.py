"""Every patch of Daphne's, Twisted's and autobahn's internals, in one place and installed by one
call, for the exact releases in ``releases`` only (the server refuses to start on others).

Each says why it is there; ``docs/performance.md`` measures what it saves, and
``tests/site/test_server_patches.py`` names every private part it uses (a canary per part).
"""

from __future__ import annotations

from functools import partialmethod


def install() -> None:
    from daphne.http_protocol import HTTPFactory, WebRequest
    from daphne.ws_protocol import WebSocketProtocol

    from server.patches import direct_frames, reaping, refused_handshakes
    from server.patches.releases import SERVER_PATCHES

    SERVER_PATCHES.refuse_others()
    # Same autobahn ordering issue as the robot link (robot/link/rosclient.py): without a class
    # default, browsers' websockets keep Nagle on and small frames stall on delayed ACKs.
    WebSocketProtocol.tcpNoDelay = True
    # The live hub writes pre-encoded frames straight to each connection. It and reaping both wrap
    # Server.create_application, each calling the one it found; this order is the one measured.
    direct_frames.install()
    # Daphne forgets a finished request at once, not at its next once-a-second sweep.
    reaping.install()
    # A malformed Host or Origin is refused by autobahn with one warning line, not a CRITICAL traceback.
    refused_handshakes.install()
    # Twisted parses POSTed form bodies itself (Daphne never reads the result) and answers a body it
    # cannot parse with a bare, empty 400 before Django sees it; let Django give its usual error.
    WebRequest.__init__ = partialmethod(WebRequest.__init__, parsePOSTFormSubmission=False)
    # Daphne writes its own access log line per request and sends Twisted's log nowhere, but the
    # embedded link's roslibpy routes Twisted's log to Python logging again: each request was logged a
    # second time in Twisted's format, through three loggers (an eighth of the state API's CPU).
    HTTPFactory.log = lambda self, request: None
