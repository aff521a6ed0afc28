import asyncio

from robot.live.fanout import BURST, Coalescer
from tests.helpers import DEADLINE_S


async def test_it_forwards_the_latest_value_at_the_ui_rate():
    sent = []
    loop = asyncio.get_running_loop()

    async def send(value):
        sent.append((value, loop.time()))

    coalescer = Coalescer(send, loop=loop)
    start = loop.time()
    for i in range(100):
        coalescer.offer("pose", 10.0, i)
    await asyncio.sleep(0.35)
    coalescer.close()
    first, at = sent[0]
    assert first < BURST and at - start < 0.05, "the first messages go out at once (latest of them wins)"
    assert sent[-1][0] == 99, "the latest value always arrives"
    assert len(sent) <= 3
    assert sent[-1][1] - start >= 0.09, "the rest waits for the next token, a period later"


async def test_it_never_holds_a_message_after_a_quiet_spell_even_right_after_a_bunched_pair():
    sent = []

    async def send(value):
        sent.append(value)

    coalescer = Coalescer(send, loop=asyncio.get_running_loop())
    # 10 Hz at a 10 Hz UI rate, delivered unevenly by a loaded machine: one late by 30 ms, the
    # next early by 30 ms (70 ms after it), then one early again. Each is the first in its period.
    await _offer_none_held_back(coalescer, sent, (0.0, 0.13, 0.07, 0.09, 0.13, 0.07, 0.1, 0.1))
    coalescer.close()


async def test_it_keeps_every_message_of_event_topics_in_order():
    sent = []

    async def send(value):
        sent.append(value)

    coalescer = Coalescer(send, loop=asyncio.get_running_loop())
    for i in range(50):
        coalescer.offer("rosout", None, i)
    await asyncio.sleep(0.05)
    coalescer.close()
    assert sent == list(range(50))


async def test_it_bounds_its_backlog_when_the_layer_is_slow():
    gate = asyncio.Event()
    sent = []

    async def send(value):
        await gate.wait()
        sent.append(value)

    coalescer = Coalescer(send, loop=asyncio.get_running_loop(), max_backlog=10)
    for i in range(100):
        coalescer.offer("rosout", None, i)
    await asyncio.sleep(0.01)
    gate.set()
    await asyncio.sleep(0.05)
    coalescer.close()
    assert coalescer.dropped >= 89
    assert sent[-1] == 99 and len(sent) <= 11


async def test_it_passes_a_topic_published_at_its_ui_rate_straight_through_after_a_late_message():
    sent = []

    async def send(value):
        sent.append(value)

    coalescer = Coalescer(send, loop=asyncio.get_running_loop())
    # 10 Hz topic at a 10 Hz UI rate: one message arrives 10 ms late, the next ones on time
    # (90 ms after it). None may be held back, or the lag would stick to every later message.
    await _offer_none_held_back(coalescer, sent, (0.0, 0.11, 0.09, 0.1, 0.1))
    coalescer.close()


async def test_a_topic_at_its_ui_rate_is_passed_straight_through_again_soon_after_a_burst():
    sent = []

    async def send(value):
        sent.append(value)

    coalescer = Coalescer(send, loop=asyncio.get_running_loop())
    for i in range(3):  # a burst (a reconnect replaying messages): the third waits for a token
        coalescer.offer("odom", 10.0, -1 - i)
    for i in range(8):  # then on rate, 10 Hz: the pacing must not lock onto a phase that holds each one
        await asyncio.sleep(0.1)
        coalescer.offer("odom", 10.0, i)
        for _ in range(3):
            await asyncio.sleep(0)
        if i >= 5:
            assert sent[-1] == i, f"message {i} was held back"
    coalescer.close()


async def _offer_none_held_back(coalescer, sent: list, gaps: tuple[float, ...]) -> None:
    """Offer odometry 0, 1, … (10 Hz UI rate) after each of ``gaps``; each must go out within a few loop turns."""
    for i, gap in enumerate(gaps):
        await asyncio.sleep(gap)
        coalescer.offer("odom", 10.0, i)
        for _ in range(3):
            await asyncio.sleep(0)
        assert sent == list(range(i + 1)), f"message {i} was held back"


async def test_closing_it_ends_its_sender_mid_send():
    """The link's stop closes the fan-out, then waits for its sender: it must not wait for a next update."""
    sending = asyncio.Event()

    async def send(value):
        sending.set()
        await asyncio.sleep(10)

    coalescer = Coalescer(send, loop=asyncio.get_running_loop())
    coalescer.offer("pose", 10.0, 1)
    await asyncio.wait_for(sending.wait(), 1)
    coalescer.close()
    done, _ = await asyncio.wait({coalescer._task}, timeout=DEADLINE_S)
    assert done, "the sender went on"


async def test_a_queue_length_keeps_only_that_many_of_a_topic_waiting_the_oldest_dropped():
    sent = []
    release = asyncio.Event()

    async def send(value):
        await release.wait()  # a slow client
        sent.append(value)

    coalescer = Coalescer(send, loop=asyncio.get_running_loop())
    for i in range(10):
        coalescer.offer("log", None, ("log", i), queue_length=3)
        coalescer.offer("events", None, ("events", i))
    await asyncio.sleep(0.01)
    release.set()
    await asyncio.sleep(0.05)
    coalescer.close()
    assert [i for key, i in sent if key == "log"] == [7, 8, 9]  # the newest 3 of the queued topic
    assert [i for key, i in sent if key == "events"] == list(range(10))  # and every one of the other
    assert coalescer.dropped == 7


async def test_a_rate_change_applies_to_the_next_message():
    sent = []
    loop = asyncio.get_running_loop()

    async def send(value):
        sent.append(loop.time())

    coalescer = Coalescer(send, loop=loop)
    for _ in range(20):
        coalescer.offer("pose", 100.0, 0)
        await asyncio.sleep(0.01)
    fast = len(sent)
    for _ in range(30):
        coalescer.offer("pose", 5.0, 0)
        await asyncio.sleep(0.01)
    coalescer.close()
    assert fast >= 15 and len(sent) - fast <= 1 + BURST  # 0.3 s at 5 Hz: its burst and a token at most
