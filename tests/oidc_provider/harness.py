"""``OidcProvider``: the tests' own OpenID Connect provider (``serve.py``) as a separate process, with
the users and the one client a test asks for, plus key rotation and token minting for tests of the
product's ID token checks."""

from __future__ import annotations

import atexit
import json
import secrets
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from types import TracebackType
from typing import Any, Self

import requests
from jwcrypto import jwk, jwt

from tests.stack import free_port

ROOT = Path(__file__).resolve().parents[2]
START_TIMEOUT_S = 30.0


@dataclass(frozen=True)
class ProviderUser:
    """A user the provider knows; ``name`` (the ``name`` claim) defaults to the username."""

    username: str
    password: str
    groups: list[str] = field(default_factory=list)
    email: str = ""
    name: str = ""
    email_verified: bool = True


class OidcProvider:
    """One provider process; ``issuer`` is ``http://127.0.0.1:PORT/o``."""

    def __init__(self, *, users: list[ProviderUser], client_id: str, client_secret: str,
                 redirect_uris: list[str], post_logout_redirect_uris: list[str] | None = None,
                 port: int | None = None, token_lifetime_s: int = 300, data_dir: Path | None = None) -> None:
        self.port = port or free_port()
        self.issuer = f"http://127.0.0.1:{self.port}/o"
        self.base_url = f"http://127.0.0.1:{self.port}"
        self.users = users
        self.client_id = client_id
        self.client_secret = client_secret
        self.redirect_uris = redirect_uris
        self.post_logout_redirect_uris = post_logout_redirect_uris or []
        self.token_lifetime_s = token_lifetime_s
        self._keep_data = data_dir is not None
        self.data_dir = data_dir or Path(tempfile.mkdtemp(prefix="oidc-provider-"))
        self.log_path = self.data_dir / "provider.log"
        self._control_token = secrets.token_urlsafe(24)
        self._process: subprocess.Popen[bytes] | None = None

    def start(self) -> None:
        self.data_dir.mkdir(parents=True, exist_ok=True)
        (self.data_dir / "spec.json").write_text(json.dumps({
            "control_token": self._control_token,
            "token_lifetime_s": self.token_lifetime_s,
            "users": [{**asdict(user), "name": user.name or user.username} for user in self.users],
            "client": {"client_id": self.client_id, "client_secret": self.client_secret,
                       "redirect_uris": self.redirect_uris,
                       "post_logout_redirect_uris": self.post_logout_redirect_uris},
        }))
        with self.log_path.open("wb") as log:
            self._process = subprocess.Popen(
                [sys.executable, "-m", "tests.oidc_provider.serve", "--port", str(self.port),
                 "--data", str(self.data_dir)],
                cwd=ROOT, stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
        atexit.register(self.stop)
        self._wait_until_up()

    def _wait_until_up(self) -> None:
        """Until this very process answers (another server on the port would not know the control token)."""
        assert self._process is not None
        process, deadline = self._process, time.monotonic() + START_TIMEOUT_S
        while True:
            if process.poll() is not None:
                self.stop()
                raise RuntimeError(f"OIDC provider exited with {process.returncode}:\n{self._log()}")
            try:
                self._control("GET", "keys", timeout_s=2)
                return
            except requests.RequestException:
                pass
            if time.monotonic() > deadline:
                self.stop()
                raise RuntimeError(f"OIDC provider not up after {START_TIMEOUT_S:g} s:\n{self._log()}")
            time.sleep(0.05)

    def _log(self) -> str:
        return self.log_path.read_text(errors="replace") if self.log_path.exists() else ""

    def stop(self) -> None:
        atexit.unregister(self.stop)
        process, self._process = self._process, None
        if process is not None and process.poll() is None:
            process.terminate()
            try:
                process.wait(5)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()
        if not self._keep_data and process is not None and process.returncode in (0, -15):
            shutil.rmtree(self.data_dir, ignore_errors=True)

    def __enter__(self) -> Self:
        self.start()
        return self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 traceback: TracebackType | None) -> None:
        self.stop()

    @property
    def discovery_url(self) -> str:
        return f"{self.issuer}/.well-known/openid-configuration"

    @property
    def jwks_url(self) -> str:
        return f"{self.issuer}/.well-known/jwks.json"

    def _control(self, method: str, path: str, timeout_s: float = 10, body: Any = None) -> Any:
        response = requests.request(method, f"{self.base_url}/test/{path}", json=body,
                                    headers={"X-Test-Control": self._control_token}, timeout=timeout_s)
        response.raise_for_status()
        return response.json()

    def rotate_key(self) -> str:
        """A new active signing key; the previous stays in the JWKS, the one before it leaves. Its kid."""
        return self._control("POST", "rotate-key")["kid"]

    def set_groups(self, username: str, groups: list[str]) -> None:
        """``username``'s ``groups`` claim from the next login on."""
        self._control("POST", f"users/{username}/groups", body=groups)

    def claims_at(self, where: str) -> None:
        """Where e-mail and groups are given from the next login on: ``id_token`` (the default, and at
        userinfo too), ``userinfo`` (only there), ``distributed`` (groups at a source the claims name, with
        an access token for it), ``pointer_only`` (groups only pointed at, without an access token, as
        Entra ID does past 200 groups) or ``userinfo_other_sub`` (only at userinfo, for another subject)."""
        self._control("POST", "claims-at", body={"where": where})

    def misbehave(self, mischief: str) -> None:
        """The token endpoint's next ID token is broken: ``tampered`` (a claim changed after signing),
        ``wrong_audience``, ``wrong_issuer``, ``expired``, ``wrong_nonce``, ``unknown_key`` (signed by a key never
        published) or ``no_id_token``."""
        self._control("POST", "misbehave", body={"mischief": mischief})

    def signing_keys(self) -> dict[str, Any]:
        """``{"active": pem, "inactive": [pem, ...]}``: the private keys, as PEM."""
        return self._control("GET", "keys")

    def mint_id_token(self, claims: dict[str, Any], *, key_pem: str | None = None, kid: str | None = None) -> str:
        """An RS256 JWT with exactly ``claims``, signed with ``key_pem`` (default: the active key);
        its header's ``kid`` is ``kid``, else the key's thumbprint, as the JWKS publishes it."""
        key = jwk.JWK.from_pem((key_pem or self.signing_keys()["active"]).encode())
        token = jwt.JWT(header={"alg": "RS256", "typ": "JWT", "kid": kid or key.thumbprint()}, claims=claims)
        token.make_signed_token(key)
        return token.serialize()
