"""The exact Daphne, Twisted and autobahn releases the server patches were written and measured
against (this package's modules and ``install``, and ``cyborg_site.drain``; each says why it is
there, ``docs/performance.md`` what it saves). Another release may have changed what they touch,
so the server refuses to start on one: check the patches against it
(``tests/site/test_server_patches.py`` names every private part they use), then move these pins
and the lock together.
"""

from __future__ import annotations

from cyborg_site.releases import Pinned

SERVER_PATCHES = Pinned("the server patches", {"daphne": "4.2.3", "twisted": "26.10.0", "autobahn": "26.10.2"},
                        see="server/patches/releases.py", check_id="server.E001")
