"""The emergency stop, all of it.

- ``rule``: which commands the latch holds back (every command the pipeline runs is declared here;
  ``robot.apps`` installs it, with ``latch.ensure_released``, as the pipeline's gate).
- ``latch``: engaging, reading and releasing it in the shared store, every process alike.
- ``stop``: the press (every step side by side, the report within a second, one audit entry) and the
  release. Features add their own steps (drive lock, talk, navigation) through ``register_step``,
  installed by ``robot.apps``, so this folder imports none of them.
- ``access``, ``views``, ``urls``: who may press it with the database down, and the API.

What the latch holds (who pressed, when, what each step did) is ``robot.live.latchstate``: the link
reads it too, and the link stands below this folder. The link's side of the stop stays with the
link: ``robot.link.guard`` (the last check on every publish: zero held, motion refused,
``robot.interface.passes_latch`` says what passes),
``robot.link.direct`` (the stop's own path to the link without Redis) and ``robot.link.standby``
(a standby link that stops the robot during a failover).
"""
