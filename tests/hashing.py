"""Password hashing for the suite: production's PBKDF2 with few rounds.

Every test user costs a hash (and every login a verification); at production's million rounds
that is a quarter of a CPU second each, hundreds of times per pass. The algorithm name and the
hash format stay production's, so a server process started by a test verifies these hashes too.
"""

from __future__ import annotations

from django.contrib.auth.hashers import PBKDF2PasswordHasher


class FewRoundsPBKDF2PasswordHasher(PBKDF2PasswordHasher):
    iterations = 1_000
