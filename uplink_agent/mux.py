"""The uplink's frames: many channels over one websocket. Shared by the agent and the server.

Each websocket message is binary: one byte of kind, four of channel id (big-endian), the payload.
The server opens channels (it asks; the agent reaches only its own rosbridge and its own video
server, at addresses it was configured with), either side closes them.

  OPEN    server -> agent  JSON {"kind": "rosbridge"} or {"kind": "http", "path": "/stream", "query": "..."}
  OPENED  agent -> server  empty: the rosbridge session is open
  HEAD    agent -> server  JSON {"status": 200, "headers": {"Content-Type": ...}}: an HTTP answer begins
  DATA    either way       one rosbridge message (UTF-8 JSON), or a piece of an HTTP body
  CLOSE   either way       UTF-8 reason: the channel is over
  STAMPED server -> agent  as DATA, after 8 bytes of the server's monotonic clock when it sent it
                           (a double, seconds): the agent can tell a message that waited in a stall
"""

import json
import struct

OPEN, OPENED, HEAD, DATA, CLOSE, STAMPED = 1, 2, 3, 4, 5, 6
KINDS = (OPEN, OPENED, HEAD, DATA, CLOSE, STAMPED)
# The only paths the agent fetches from the robot's video server.
HTTP_PATHS = ("/stream", "/snapshot")
_HEAD = struct.Struct("!BI")
_STAMP = struct.Struct("!d")


class BadFrame(ValueError):
    pass


def encode(kind, channel, payload=b""):
    return _HEAD.pack(kind, channel) + payload


def encode_json(kind, channel, value):
    return encode(kind, channel, json.dumps(value, separators=(",", ":")).encode())


def encode_stamped(channel, stamp, payload):
    return _HEAD.pack(STAMPED, channel) + _STAMP.pack(stamp) + payload


def split_stamp(payload):
    """(stamp, message) of a STAMPED frame's payload."""
    if len(payload) < _STAMP.size:
        raise BadFrame("a stamped frame without its stamp")
    return _STAMP.unpack_from(payload)[0], payload[_STAMP.size:]


def decode(message):
    """(kind, channel, payload) of one uplink message; BadFrame if it is not one."""
    if not isinstance(message, (bytes, bytearray)) or len(message) < _HEAD.size:
        raise BadFrame("not an uplink frame")
    kind, channel = _HEAD.unpack_from(message)
    if kind not in KINDS:
        raise BadFrame("unknown frame kind %d" % kind)
    return kind, channel, bytes(message[_HEAD.size:])


def decode_json(payload):
    try:
        value = json.loads(payload.decode())
    except ValueError:
        raise BadFrame("a frame whose payload is not JSON")
    if not isinstance(value, dict):
        raise BadFrame("a frame whose payload is not a JSON object")
    return value
