"""Hypothesis settings of the fuzz tests, and the scale of the nightly fuzz job.

The README's test command runs every fuzz test on a fixed set of examples (derandomized: the same
examples in every run, so that a failure reproduces). With ``PORTHAMILTONIAN_FUZZ_SCALE=N`` (a
whole number >= 1) the fuzz tests draw N times as many examples, new ones on every run (not
derandomized: hypothesis prints the seed of a failure, ``@seed(...)`` replays it): the setting of
``.ci/nightly-fuzz``, which runs them on a schedule beside the command-line fuzz corpus.
"""
from __future__ import annotations

import os
from typing import Any

from hypothesis import settings


def _scale() -> int:
    text = os.environ.get("PORTHAMILTONIAN_FUZZ_SCALE", "1")
    if not text.isdigit() or int(text) < 1:
        raise ValueError(f"PORTHAMILTONIAN_FUZZ_SCALE must be a whole number >= 1, got {text!r}")
    return int(text)


#: examples drawn per example of the README's test command (1 there; the nightly job's N)
SCALE = _scale()


def fuzz_settings(max_examples: int, **options: Any) -> settings:
    """The settings of a fuzz test drawing ``max_examples`` examples in the README's test command
    (derandomized), ``SCALE`` times as many fresh ones under the nightly scale."""
    if SCALE == 1:
        return settings(max_examples=max_examples, derandomize=True, **options)
    return settings(max_examples=max_examples * SCALE, derandomize=False, **options)
