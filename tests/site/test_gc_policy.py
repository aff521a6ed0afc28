"""The web server's startup heap is frozen out of garbage collection."""

import gc
import weakref

from server.gc_policy import freeze_startup_heap


class Node:
    pass


def test_it_collects_startup_garbage_then_freezes_what_is_alive():
    garbage = Node()
    garbage.me = garbage  # a cycle: only the collector frees it
    gone = weakref.ref(garbage)
    del garbage
    alive = Node()
    try:
        frozen = freeze_startup_heap()
        assert gone() is None
        # Not equal to a later count: a frozen object freed by reference counting leaves the frozen set.
        assert frozen > 0 and gc.get_freeze_count() > 0
        assert not any(o is alive for o in gc.get_objects())  # out of the collector's sight
    finally:
        gc.unfreeze()
    assert any(o is alive for o in gc.get_objects())
