"""Any integer is a seed: negative or huge ones are hashed to a 63-bit seed.

Seeds in ``[0, 2**63)`` are used unchanged (so recorded runs stay reproducible); any other
integer (``--seed -1``, ``--seed 10**30``) is mixed by :class:`numpy.random.SeedSequence`
into that range, deterministically, instead of failing deep inside a random generator.
"""

from __future__ import annotations

import numpy as np

SEED_LIMIT = 2**63
_NEGATIVE = 0x6E656721  # entropy word marking a negative seed


def usable_seed(seed: int) -> int:
    """``seed`` itself when ``0 <= seed < 2**63``, else a deterministic hash of it there."""
    seed = int(seed)
    if 0 <= seed < SEED_LIMIT:
        return seed
    words = []
    magnitude = abs(seed)
    while magnitude:
        words.append(magnitude & 0xFFFFFFFF)
        magnitude >>= 32
    entropy = [*words, _NEGATIVE if seed < 0 else 1]
    state = np.random.SeedSequence(entropy).generate_state(2, dtype=np.uint32)
    return (int(state[0]) << 31) ^ int(state[1])
