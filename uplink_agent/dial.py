"""Opening the uplink: TLS to the server (through an HTTP proxy's CONNECT if one is set), then the
websocket handshake with the robot's credential in a header."""

import asyncio
import base64
import ipaddress
import socket
import ssl
from urllib.parse import unquote, urlsplit

from . import ws

USER_AGENT = "cyborg-uplink-agent/1.0"


def is_loopback(host):
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def check_server_url(url):
    """The server's address, refused unless it is wss:// (or ws:// to this computer's loopback)."""
    parts = urlsplit(url)
    if parts.scheme == "wss" and parts.hostname:
        return url
    if parts.scheme == "ws" and parts.hostname and is_loopback(parts.hostname):
        return url
    raise ValueError("the server address must be wss://HOST/... (plain ws:// only to loopback): %r" % url)


def connect_through_proxy(proxy_url, host, port, timeout):
    """A socket tunnelled to host:port by an HTTP proxy's CONNECT (blocking: run it in an executor)."""
    proxy = urlsplit(proxy_url)
    if proxy.scheme != "http" or not proxy.hostname:
        raise ValueError("the proxy must be http://[USER:PASSWORD@]HOST:PORT: %r" % proxy_url)
    sock = socket.create_connection((proxy.hostname, proxy.port or 3128), timeout)
    try:
        lines = ["CONNECT %s:%d HTTP/1.1" % (host, port), "Host: %s:%d" % (host, port)]
        if proxy.username is not None:
            user = "%s:%s" % (unquote(proxy.username), unquote(proxy.password or ""))
            lines.append("Proxy-Authorization: Basic " + base64.b64encode(user.encode()).decode())
        sock.sendall(("\r\n".join(lines) + "\r\n\r\n").encode("latin-1"))
        head = b""
        while not head.endswith(b"\r\n\r\n"):  # byte by byte: nothing after the head may be taken from TLS
            byte = sock.recv(1)
            if not byte or len(head) > 8192:
                raise OSError("the proxy closed the connection or sent no answer")
            head += byte
        status = head.split(b" ", 2)[1] if head.count(b" ") >= 2 else b""
        if status != b"200":
            raise OSError("the proxy refused CONNECT: %s" % head.split(b"\r\n", 1)[0].decode("latin-1"))
        sock.settimeout(None)
        return sock
    except BaseException:
        sock.close()
        raise


async def open_uplink(server_url, credential, ca_file="", proxy_url="", timeout=10.0, max_size=64 * 1024 * 1024):
    """An open websocket to the server's uplink endpoint."""
    parts = urlsplit(check_server_url(server_url))
    secure = parts.scheme == "wss"
    host, port = parts.hostname, parts.port or (443 if secure else 80)
    context = ssl.create_default_context(cafile=ca_file or None) if secure else None
    loop = asyncio.get_event_loop()
    if proxy_url:
        sock = await loop.run_in_executor(None, connect_through_proxy, proxy_url, host, port, timeout)
        opening = asyncio.open_connection(sock=sock, ssl=context, server_hostname=host if secure else None)
    else:
        opening = asyncio.open_connection(host, port, ssl=context, server_hostname=host if secure else None)
    reader, writer = await asyncio.wait_for(opening, timeout)
    try:
        nodelay(writer)
        headers = {"Authorization": "Bearer " + credential, "User-Agent": USER_AGENT}
        return await asyncio.wait_for(
            ws.handshake(reader, writer, parts.netloc, parts.path or "/", headers, max_size=max_size), timeout)
    except BaseException:
        writer.close()
        raise


def nodelay(writer):
    sock = writer.get_extra_info("socket")
    if sock is not None:
        try:
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        except OSError:
            pass
