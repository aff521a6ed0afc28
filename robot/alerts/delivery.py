"""Alerts beyond the tab (filled in by the delivery slice)."""


def install() -> None:
    return None
