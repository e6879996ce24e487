"""Turning scikit-learn's `random_state` convention into a numpy Generator."""

from __future__ import annotations

import numbers

import numpy as np


def make_generator(random_state) -> np.random.Generator:
    """A Generator for `random_state` without touching numpy's or torch's global state.

    Parameters
    ----------
    random_state : None, int, numpy.random.RandomState or numpy.random.Generator
        None draws fresh entropy (not reproducible); an int gives the same stream every time; a
        RandomState or Generator seeds a new Generator from one draw of it.
    """
    if random_state is None:
        return np.random.default_rng()
    if isinstance(random_state, numbers.Integral) and not isinstance(random_state, bool):
        return np.random.default_rng(int(random_state))
    if isinstance(random_state, np.random.RandomState):
        return np.random.default_rng(random_state.randint(np.iinfo(np.int32).max))
    if isinstance(random_state, np.random.Generator):
        return np.random.default_rng(random_state.integers(np.iinfo(np.int64).max))
    raise ValueError(
        f"random_state must be None, an int, a RandomState or a Generator; got {random_state!r}."
    )
