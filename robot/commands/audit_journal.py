"""Audit entries the database could not take wait on this machine's disk until it can.

Each process appends to a file of its own under ``AUDIT_JOURNAL_DIR``, one JSON line per entry,
flushed to disk before the caller goes on; ``replay`` writes every journal's entries (any
process's, a dead one's too) with the time they happened, and empties the journal in the same
lock. So an E-STOP pressed while the database is down is audited when it returns, and nothing
anyone sent to the robot goes unrecorded.
"""

from __future__ import annotations

import fcntl
import json
import logging
import os
import time
import uuid
from collections.abc import Iterator
from contextlib import contextmanager
from datetime import UTC, datetime
from pathlib import Path
from typing import IO, Any

from django.conf import settings
from django.db import transaction

from cyborg_site.client_address import client_address
from cyborg_site.text import scrub, scrub_json
from robot.models import AuditEntry

log = logging.getLogger(__name__)
TAKEN_PREFIX = "audit-taken-"


def _folder() -> Path:
    return Path(settings.AUDIT_JOURNAL_DIR)


def _own_file() -> Path:
    return _folder() / f"audit-{os.getpid()}.jsonl"


@contextmanager
def _locked(path: Path, mode: str) -> Iterator[IO[str]]:
    with open(path, mode, encoding="utf-8") as f:
        fcntl.flock(f, fcntl.LOCK_EX)
        try:
            yield f
        finally:
            fcntl.flock(f, fcntl.LOCK_UN)


def keep(fields: dict[str, Any]) -> None:
    """Journal one entry (``audit_record``'s fields) durably."""
    user = fields.get("user")
    authenticated = user is not None and getattr(user, "is_authenticated", False)
    entry = {
        "at": time.time(), "user_id": getattr(user, "pk", None) if authenticated else None,
        "username": getattr(user, "username", "") if authenticated else "",
        **{k: fields.get(k) for k in ("source", "action", "params", "ok", "outcome", "error_code")},
        "address": fields.get("address") or client_address.get(),
    }
    _folder().mkdir(parents=True, exist_ok=True)
    while True:
        with _locked(_own_file(), "a") as f:
            if not _still_there(f):
                continue  # a replay emptied and removed it between our open and our lock
            f.write(json.dumps(entry, default=str) + "\n")
            f.flush()
            os.fsync(f.fileno())
            break


def _still_there(f: IO[str]) -> bool:
    try:
        return os.stat(f.name).st_ino == os.fstat(f.fileno()).st_ino
    except FileNotFoundError:
        return False


def pending() -> int:
    """Entries waiting in every journal."""
    count = 0
    for path in _folder().glob("audit-*.jsonl"):
        with open(path, encoding="utf-8") as f:
            count += sum(1 for line in f if line.strip())
    return count


def replay() -> int:
    """Write every journaled entry to the database and empty the journals; how many were written.
    Raises the database's error (the entries are kept) while it is still down.

    Each journal is first taken aside (renamed, under its lock), so writers append to a fresh one
    and never wait on a database that hangs; a taken file is locked while it is written, so two
    processes never write the same one, and removed once written."""
    for path in sorted(_folder().glob("audit-*.jsonl")):
        if not path.name.startswith(TAKEN_PREFIX):
            _take(path)
    written = 0
    for path in sorted(_folder().glob(f"{TAKEN_PREFIX}*.jsonl")):
        with open(path, encoding="utf-8") as f:
            try:
                fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                continue  # another process is writing it
            if not _still_there(f):
                continue
            entries = [json.loads(line) for line in f.read().splitlines() if line.strip()]
            if entries:
                _write(entries)
                written += len(entries)
            path.unlink()
    if written:
        log.info("audit: wrote %d journaled entries", written)
    return written


def _take(path: Path) -> None:
    try:
        with _locked(path, "r") as f:
            if _still_there(f):
                path.rename(path.with_name(f"{TAKEN_PREFIX}{uuid.uuid4().hex}.jsonl"))
    except FileNotFoundError:
        pass  # another process took it first


def _write(entries: list[dict[str, Any]]) -> None:
    from django.contrib.auth import get_user_model

    ids = {e["user_id"] for e in entries if e.get("user_id") is not None}
    known = set(get_user_model().objects.filter(pk__in=ids).values_list("pk", flat=True))
    with transaction.atomic():
        for entry in entries:
            row = AuditEntry.objects.create(
                user_id=entry["user_id"] if entry.get("user_id") in known else None, username=entry["username"],
                source=entry["source"] or "system", action=entry["action"] or "",
                params=scrub_json(entry["params"] or {}), ok=bool(entry["ok"]),
                outcome=scrub(str(entry["outcome"] or "")[:2000]), error_code=entry["error_code"] or "",
                address=str(entry.get("address") or ""))
            # The row says when it happened, not when the database came back.
            AuditEntry.objects.filter(pk=row.pk).update(created=datetime.fromtimestamp(entry["at"], tz=UTC))
