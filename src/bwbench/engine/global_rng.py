"""For libraries that draw from numpy's legacy global generator (pyswarms; ``cma.fmin``, which reseeds
it from the clock): seed it from the run's ``Generator`` for the duration of the call, and restore it.

    with seeded_global_rng(rng):
        library.optimize(...)

A lock serialises such runs within a process, since two threads sharing the global generator would
interleave draws; code outside that draws from ``np.random`` in another thread meanwhile still
disturbs the run.
"""

from __future__ import annotations

import contextlib
import threading

import numpy as np

_LOCK = threading.Lock()


@contextlib.contextmanager
def seeded_global_rng(rng: np.random.Generator):
    """Seed numpy's legacy global generator from ``rng`` for the duration; restore it after."""
    with _LOCK:
        saved = np.random.get_state()
        # A full MT19937 state seeded through SeedSequence, not a 32-bit np.random.seed.
        np.random.set_state(np.random.RandomState(np.random.MT19937(rng.integers(2**63))).get_state())
        try:
            yield
        finally:
            np.random.set_state(saved)
