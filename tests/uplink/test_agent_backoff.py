"""The agent's reconnect delays: growing, capped, jittered (robots restarted together do not dial in step)."""

from __future__ import annotations

from uplink_agent.agent import backoff


def test_it_grows_to_its_cap_and_never_past_it() -> None:
    ceilings = [max(backoff(attempt, 0.25, 10.0) for _ in range(200)) for attempt in range(10)]
    assert ceilings[0] <= 0.25 and ceilings[3] <= 2.0 < ceilings[6] <= 10.0
    assert all(backoff(attempt, 0.25, 10.0) <= 10.0 for attempt in range(100))


def test_two_agents_starting_together_spread_out() -> None:
    delays = {round(backoff(5, 0.25, 10.0), 3) for _ in range(50)}
    assert len(delays) > 10 and min(delays) >= 4.0  # jitter in [cap/2, cap]
