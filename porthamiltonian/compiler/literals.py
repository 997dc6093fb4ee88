"""Escaping of untrusted text (model, state, parameter and output names) for generated source.

Names come from model files and command lines and may contain anything: quotes, backslashes,
comment terminators, newlines, non-ASCII characters. Generated code only ever embeds them in
comments and docstrings, through these functions, so no name can end a comment or a string early.
"""
from __future__ import annotations


def _ascii(text: str) -> str:
    """``text`` as printable ASCII: backslash, control and non-ASCII characters as escapes."""
    out = []
    for ch in str(text):
        if ch == "\\":
            out.append("\\\\")
        elif " " <= ch <= "~":
            out.append(ch)
        else:
            code = ord(ch)
            out.append(f"\\x{code:02x}" if code < 0x100 else
                       f"\\u{code:04x}" if code < 0x10000 else f"\\U{code:08x}")
    return "".join(out)


def python_docstring(text: str) -> str:
    """``text`` safe inside a ``\"\"\"...\"\"\"`` docstring: printable ASCII, backslashes and
    double quotes escaped (the docstring's value reads back as the original text)."""
    return _ascii(text).replace('"', '\\"')


def c_comment(text: str) -> str:
    """``text`` safe inside a C ``/* ... */`` comment: printable ASCII on one line (escapes as
    in :func:`python_docstring`), ``*/`` and ``/*`` broken up. (No trigraph yields ``*`` or
    ``/``, so none can close the comment.)"""
    return _ascii(text).replace("*/", "* /").replace("/*", "/ *")


def printable(text: str) -> str:
    """``text`` as printable ASCII for a terminal line (no control sequences, no newlines)."""
    return _ascii(text)
