"""Errors of the batch layer: an ill-defined sweep, a results file that must not be written.

Both are :class:`~porthamiltonian.errors.ModelError` subclasses (bad input), so the command
lines report them as ``error: ...`` with exit status 2.
"""
from __future__ import annotations

from ..errors import ModelError

__all__ = ["SweepError", "SweepFileError"]


class SweepError(ModelError):
    """A parameter sweep is ill-defined: a bad grid specification, an option the case function
    does not take, a case function that worker processes cannot import, an unknown analysis."""


class SweepFileError(SweepError):
    """A sweep results file cannot be resumed: it is a directory, its header is missing or
    foreign, it belongs to a different sweep, a row in its middle is corrupt, or another running
    sweep holds it. The file is left unchanged; the message names the file, the line and what
    to do."""
