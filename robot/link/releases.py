"""The exact roslibpy, Twisted and autobahn releases the robot link's hooks into their private parts
were written for: ``rosclient`` dispatches through the protocol's ``_message_handlers``, replaces the
factory's ``_connect`` (a verified wss:// connection), stops a manager's ``_log_observer`` and relies
on autobahn reading ``tcpNoDelay`` before the factory's options; ``status`` and ``connection`` read
the factory's ``_proto`` and cancel Twisted's pending retry, ``_callID``; ``subscriptions`` sends a
topic's ``_connect_message`` again on a new connection. Another release may have
changed them, so the link refuses to start on one (``manage.py robotlink`` and the embedded link):
check the hooks against it (``tests/link/test_roslibpy_canaries.py`` names each part), then move
these pins, pyproject.toml's and the lock together.
"""

from __future__ import annotations

from cyborg_site.releases import Pinned

LINK_HOOKS = Pinned("the robot link's hooks into roslibpy and Twisted",
                    {"roslibpy": "2.1.0", "twisted": "26.10.0", "autobahn": "26.10.2"},
                    see="robot/link/releases.py", check_id="robot.E004")
