"""The robot's microphone as pages play it: raw PCM relayed as it is, mp3 decoded to PCM here.

mp3 is decoded on the server, once per chunk where the link receives it (however many pages
listen), with FFmpeg's decoder through PyAV, and pages get S16LE like any ``wave`` microphone.
Decoding in the browser was tried and is the wrong tool for a live stream:

- ``decodeAudioData`` decodes whole files. Each call is a fresh decoder, so a small group of
  frames has lost the bit reservoir of the frames before it (Chromium rejects many such groups
  outright), and each decoded group carries the decoder's own delay and padding, so groups
  played back to back click and drift: gap-free playback is not what that API gives.
- WebCodecs' ``AudioDecoder`` keeps state, but only in secure contexts, and a ground station on
  a LAN is often plain HTTP; some browsers lack it.

A continuous decoder keeps the reservoir across chunks, and its failures are seen on the server,
which tells the listening pages (never a silent page). Pages keep one playback path for every
robot format. The cost is PCM to each listener instead of mp3 (256 kbit/s for 16 kHz mono),
small on the robot's network.

The decoder is handed whole MPEG frames, found from their 4-byte headers (ISO/IEC 11172-3 and
13818-3): a chunk on the topic may end mid-frame, and PyAV's parser, fed a stream piecewise,
hands back frames torn at the chunk boundaries.
"""

from __future__ import annotations

from typing import Any

import av

# What pages assume when the robot has not said what its microphone sends.
DEFAULT_INFO: dict[str, Any] = {"channels": 1, "sample_rate": 16000, "sample_format": "S16LE",
                                "bitrate": 256000, "coding_format": "wave"}
PCM_CODINGS = ("wave", "wav", "pcm", "raw")
CODINGS = (*PCM_CODINGS, "mp3")
BYTES_PER_SAMPLE = 2
# After a (re)start the first frames may point into a bit reservoir this decoder never saw.
WARMUP_FRAMES = 3
# The largest Layer III frame is 1441 bytes: this much without one is not mp3.
MAX_UNFRAMED = 8192


class Unplayable(ValueError):
    """The microphone's declared format cannot be played."""


class DecodeError(ValueError):
    """Microphone audio did not decode."""


def playback_format(info: dict[str, Any] | None) -> dict[str, Any]:
    """What listening pages receive for a microphone that declares ``info``: always S16LE
    ("wave"), with the robot's own coding in ``robot_coding_format``. Raises Unplayable."""
    info = info or DEFAULT_INFO
    coding = str(info.get("coding_format") or "wave").lower()
    if coding not in CODINGS:
        raise Unplayable(f"The robot's microphone sends {coding}; this station plays wave (raw PCM) and mp3.")
    sample_format = str(info.get("sample_format") or "S16LE").upper()
    if coding in PCM_CODINGS and sample_format != "S16LE":
        raise Unplayable(f"The robot's microphone sends {sample_format} samples; this station plays S16LE.")
    try:
        channels, rate = int(info.get("channels") or 1), int(info.get("sample_rate") or 16000)
    except (TypeError, ValueError):
        raise Unplayable(f"The robot's microphone declares an unreadable format: {info!r}") from None
    if channels not in (1, 2) or not 8000 <= rate <= 48000:
        raise Unplayable(f"The robot's microphone declares {channels} channels at {rate} Hz; "
                         "this station plays mono or stereo at 8-48 kHz.")
    return {"channels": channels, "sample_rate": rate, "sample_format": "S16LE", "coding_format": "wave",
            "robot_coding_format": coding}


class PcmRelay:
    """Raw PCM passes as it is, whole sample frames only (a torn chunk would shift the rest)."""

    def __init__(self, channels: int) -> None:
        self.frame = channels * BYTES_PER_SAMPLE
        self.pending = b""

    def feed(self, data: bytes) -> bytes:
        data = self.pending + data
        whole = len(data) - len(data) % self.frame
        self.pending = data[whole:]
        return data[:whole]


# MPEG audio header tables, indexed by the header's version bits (3: MPEG-1, 2: MPEG-2, 0: MPEG-2.5).
_KBPS_V1 = (0, 32, 40, 48, 56, 64, 80, 96, 112, 128, 160, 192, 224, 256, 320)
_KBPS_V2 = (0, 8, 16, 24, 32, 40, 48, 56, 64, 80, 96, 112, 128, 144, 160)
_RATES = {3: (44100, 48000, 32000), 2: (22050, 24000, 16000), 0: (11025, 12000, 8000)}


def layer3_frame_size(b: bytes | bytearray, i: int) -> int:
    """Bytes in the Layer III frame whose header starts at ``b[i]``, or 0 if none starts there."""
    if i + 4 > len(b) or b[i] != 0xFF or (b[i + 1] & 0xE0) != 0xE0 or (b[i + 1] >> 1) & 3 != 1:
        return 0
    version, bitrate, rate = (b[i + 1] >> 3) & 3, b[i + 2] >> 4, (b[i + 2] >> 2) & 3
    if version not in _RATES or bitrate in (0, 15) or rate == 3:
        return 0
    kbps = (_KBPS_V1 if version == 3 else _KBPS_V2)[bitrate]
    per_kbps = 144 if version == 3 else 72
    return per_kbps * kbps * 1000 // _RATES[version][rate] + ((b[i + 2] >> 1) & 1)


def _same_stream(b: bytes | bytearray, i: int, j: int) -> bool:
    """Whether the headers at ``i`` and ``j`` agree on version, layer and sample rate."""
    return b[i + 1] == b[j + 1] and (b[i + 2] >> 2) & 3 == (b[j + 2] >> 2) & 3


class Mp3Decoder:
    """A continuous mp3 stream in arbitrary chunks → S16LE at the declared rate and channels.

    Frames are trusted once in sync; sync is (re)gained only on a header followed by a second,
    agreeing header where the first frame ends: joining mid-stream, the bytes of a torn frame
    often contain something that looks like a header."""

    def __init__(self, channels: int, rate: int) -> None:
        self.channels, self.rate = channels, rate
        self.codec = av.CodecContext.create("mp3", "r")
        self.resampler: av.AudioResampler | None = None
        self.source: tuple[str, str, int] | None = None
        self.pending = bytearray()
        self.frames = 0
        self.synced = False
        self.skipped = 0  # bytes passed over since the last frame

    def _whole_frames(self) -> list[bytes]:
        frames, i, b = [], 0, self.pending
        while i + 4 <= len(b):
            size = layer3_frame_size(b, i)
            if size and not self.synced:
                if i + size + 4 > len(b):
                    break  # wait for the next header to confirm this one
                self.synced = layer3_frame_size(b, i + size) > 0 and _same_stream(b, i, i + size)
            if not size or not self.synced:
                self.synced = False
                i += 1
                self.skipped += 1
                continue
            if i + size > len(b):
                break
            frames.append(bytes(b[i:i + size]))
            self.skipped = 0
            i += size
        del b[:i]
        if self.skipped > MAX_UNFRAMED:
            skipped, self.skipped = self.skipped, 0
            raise DecodeError(f"no mp3 frame in {skipped} bytes of microphone audio")
        return frames

    def _pcm(self, frame: av.AudioFrame) -> list[bytes]:
        source = (frame.format.name, frame.layout.name, frame.sample_rate)
        if source != self.source:  # the first frame, or the stream changed its format
            self.source = source
            layout = "mono" if self.channels == 1 else "stereo"
            self.resampler = av.AudioResampler(format="s16", layout=layout, rate=self.rate)
        assert self.resampler is not None
        width = self.channels * BYTES_PER_SAMPLE
        return [bytes(pcm.planes[0])[: pcm.samples * width] for pcm in self.resampler.resample(frame)]

    def feed(self, data: bytes) -> bytes:
        self.pending += data
        out: list[bytes] = []
        for frame in self._whole_frames():
            self.frames += 1
            try:
                decoded = self.codec.decode(av.Packet(frame))
            except av.error.FFmpegError as exc:
                if self.frames <= WARMUP_FRAMES:
                    continue
                raise DecodeError(f"an mp3 frame did not decode: {exc}") from exc
            for piece in decoded:
                out.extend(self._pcm(piece))
        return b"".join(out)


def decoder_for(info: dict[str, Any] | None) -> PcmRelay | Mp3Decoder:
    """The stream decoder for a microphone that declares ``info`` (raises Unplayable)."""
    fmt = playback_format(info)
    if fmt["robot_coding_format"] == "mp3":
        return Mp3Decoder(fmt["channels"], fmt["sample_rate"])
    return PcmRelay(fmt["channels"])
