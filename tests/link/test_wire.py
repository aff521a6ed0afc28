"""Large rosbridge frames: the numpy fast path gives what ``json.loads`` gives, or steps aside."""

import json
import random

import numpy as np
import pytest

from robot.link import wire
from robot.link.wire import decode_frame, parse_int_array
from robot.live.state import jsonable

MAP = "/map"
ARRAYS = frozenset({MAP})


def grid_frame(values, *, topic=MAP, separators=(",", ":"), **extra_msg):
    msg = {"header": {"seq": 3, "frame_id": "map"}, "info": {"width": len(values), "height": 1}, **extra_msg,
           "data": values}
    return json.dumps({"op": "publish", "topic": topic, "msg": msg}, separators=separators).encode()


def same(decoded, expected):
    """``decoded`` equals ``expected`` with any ndarray compared as the list it stands for."""
    return json.dumps(decoded, default=jsonable, sort_keys=True) == json.dumps(expected, sort_keys=True)


@pytest.mark.parametrize("separators", [(",", ":"), (", ", ": ")])  # ours compact, rosbridge's json.dumps spaced
def test_it_parses_a_maps_cells_into_an_array_equal_to_what_json_gives(separators):
    values = [-1, 0, 100, 55, -1, 7] * 1000
    frame = grid_frame(values, separators=separators)
    decoded = decode_frame(frame, array_topics=ARRAYS)
    assert isinstance(decoded["msg"]["data"], np.ndarray)
    assert decoded["msg"]["data"].tolist() == values
    assert same(decoded, json.loads(frame))


def test_it_agrees_with_json_on_random_arrays_across_chunk_boundaries(monkeypatch):
    monkeypatch.setattr(wire, "_CHUNK_BYTES", 7)  # many chunks, cut at every kind of place
    rng = random.Random(5)
    for _ in range(300):
        values = [rng.choice([-1, 0, 100, rng.randint(-(2**31), 2**31 - 1)]) for _ in range(rng.randint(0, 40))]
        body = rng.choice([", ", ",", " ,\n"]).join(str(v) for v in values)
        frame = b'{"op":"publish","topic":"/map","msg":{"data":[' + body.encode() + b"]}}"
        decoded = decode_frame(frame, array_topics=ARRAYS)
        assert decoded["msg"]["data"].tolist() == values


@pytest.mark.parametrize("body", ["1,,2", "1,2,", ",1", "1 2", "--1", "1-", "1.5,2", "1e3", '"a"', "[1]", "null"])
def test_it_leaves_anything_but_a_plain_integer_list_to_json(body):
    assert parse_int_array(body.encode()) is None


def test_it_copes_with_the_robots_ujson_frames_keys_in_any_order_and_escaped_slashes():
    # rosbridge with ujson on Python 2: compact, "\/" for "/", keys in hash order.
    frame = (b'{"topic":"\\/map","msg":{"info":{"width":3},"data":[0,-1,100],"header":{"frame_id":"map"}},'
             b'"op":"publish"}')
    decoded = decode_frame(frame, array_topics=ARRAYS)
    assert decoded["topic"] == MAP
    assert isinstance(decoded["msg"]["data"], np.ndarray)
    assert same(decoded, json.loads(frame))


@pytest.mark.parametrize("frame", [
    b'{"op":"publish","topic":"/map","msg":{"data":[1.5,2.5]}}',  # floats
    b'{"op":"publish","topic":"/map","msg":{"data":[[1],[2]]}}',  # nested
    b'{"op":"publish","topic":"/map","msg":{"frame_id":"a\\"data\\":[1,2]"}}',  # inside a string
    b'{"op":"publish","topic":"/map","msg":{"data":"[1,2]"}}',  # a string
    b'{"op":"publish","topic":"/map","msg":{"data":[]}}',
    b'{"op":"publish","topic":"/map","msg":{"data":[1,2],"data2":{"data":[3,4,5]}}}',  # two: the longer is cut
    b'{"op":"publish","topic":"/map","msg":{"x\\\\":0,"data":[1,2]}}',  # an escaped backslash before a key
])
def test_frames_of_other_shapes_decode_exactly_as_json_does(frame):
    assert same(decode_frame(frame, array_topics=ARRAYS), json.loads(frame))


def test_other_topics_get_plain_lists_from_the_fast_path_too():
    frame = grid_frame([1, 2, 3] * 10, topic="/move_base/global_costmap/costmap")
    decoded = decode_frame(frame, array_topics=ARRAYS)
    assert type(decoded["msg"]["data"]) is list and decoded["msg"]["data"] == [1, 2, 3] * 10


def test_a_broken_frame_is_an_error_not_a_partial_message():
    frame = b'{"op":"publish","topic":"/map","msg":{"data":[1,,2]}}'
    with pytest.raises(ValueError):
        decode_frame(frame, array_topics=ARRAYS)


def test_decoded_arrays_encode_back_to_json_lists():
    assert json.dumps({"data": np.array([-1, 0, 100], dtype=np.int32), "n": np.int64(3)}, default=jsonable) == (
        '{"data": [-1, 0, 100], "n": 3}')
    with pytest.raises(TypeError):
        json.dumps({"x": object()}, default=jsonable)
