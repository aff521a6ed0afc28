"""Single sign-on with the organisation's OpenID Connect provider, beside the local accounts.

``config`` reads the settings, ``roles`` maps a person's claims to a role, ``people`` keeps the
account an identity signs in to, ``client`` speaks the protocol (Authlib: discovery, PKCE, state,
nonce, the ID token's signature, issuer, audience and expiry, rotated keys)."""
