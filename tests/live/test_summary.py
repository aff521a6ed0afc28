"""Summarising messages for pages: long arrays and strings cut, the rest unchanged."""

import numpy as np

from robot.live.summary import HEAD_ITEMS, MAX_CHARS, MAX_ITEMS, summarise


def test_small_messages_come_back_unchanged():
    msg = {"header": {"stamp": {"secs": 1, "nsecs": 2}, "frame_id": "map"}, "data": [1, 2, 3], "text": "hi"}
    assert summarise(msg) == msg


def test_long_arrays_keep_their_length_and_first_items():
    ranges = [float(i) for i in range(541)]
    out = summarise({"ranges": ranges, "poses": [{"x": i} for i in range(MAX_ITEMS + 1)]})
    assert out["ranges"] == {"_truncated": "array", "length": 541, "items": ranges[:HEAD_ITEMS]}
    assert out["poses"]["length"] == MAX_ITEMS + 1 and out["poses"]["items"][0] == {"x": 0}


def test_numpy_arrays_and_long_strings_are_summarised_too():
    out = summarise({"data": np.arange(4_000_000, dtype=np.int32), "b64": "A" * (MAX_CHARS + 1), "n": np.int32(3)})
    assert out["data"]["length"] == 4_000_000 and out["data"]["items"][:3] == [0, 1, 2]
    assert out["b64"]["_truncated"] == "string" and out["b64"]["length"] == MAX_CHARS + 1
    assert out["n"] == 3 and isinstance(out["n"], int)
