"""Text from model files in pages and figures: the two rules, used by the 3D viewer, the
walker report and every figure.

Names, units, descriptions and other strings of a model file are hostile (``<!--<script>`` in a
model's name, a ``$`` in a unit), and they reach two interpreters:

* **HTML pages** embed data as JSON inside ``<script type="application/json">`` elements. In a
  script element the HTML parser, not JSON, decides where the element ends: ``</script>`` ends
  it, and ``<!--`` followed by ``<script`` puts the parser in a state where the next
  ``</script>`` does not, so the rest of the page becomes part of the script (the page loses its
  sections and figures, without an error). :func:`script_json` writes JSON in which ``<``, ``>``
  and ``&`` never appear as such (each is its ``\\u`` escape, which JSON.parse reads back
  unchanged), nor do U+2028 and U+2029 (line terminators to JavaScript before ES2019). Text
  outside scripts is escaped with :func:`html.escape`.
* **matplotlib** reads text between two ``$`` as mathtext, and a ``$`` in a model name or unit
  crashes the figure (ParseSyntaxException). :data:`PLAIN_TEXT` (rc settings) and
  :func:`plain_text` (a context) turn mathtext off for text created within; the project's own
  mathematical labels ask for it explicitly (``parse_math=True``).
"""
from __future__ import annotations

import contextlib
import json
from collections.abc import Iterator
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from matplotlib.typing import RcKeyType

__all__ = ["PLAIN_TEXT", "plain_text", "script_json"]

_SCRIPT_ESCAPES = {"<": "\\u003c", ">": "\\u003e", "&": "\\u0026", "\u2028": "\\u2028",
                   "\u2029": "\\u2029"}
_TABLE = str.maketrans(_SCRIPT_ESCAPES)

#: matplotlib rc settings under which text is never read as mathtext
PLAIN_TEXT: dict[RcKeyType, Any] = {"text.parse_math": False}


def script_json(data: Any, **options: Any) -> str:
    """``data`` as JSON text safe inside an HTML ``<script>`` element (module docstring):
    :func:`json.dumps` with ``options`` (default: compact separators), then ``<``, ``>``, ``&``,
    U+2028 and U+2029 replaced by their ``\\u`` escapes (they can only occur inside JSON
    strings, where the escape means the same character)."""
    options.setdefault("separators", (",", ":"))
    return json.dumps(data, **options).translate(_TABLE)


@contextlib.contextmanager
def plain_text() -> Iterator[None]:
    """Within this context, matplotlib text (titles, labels, legends, annotations) is created
    without mathtext: a ``$`` is a dollar sign (:data:`PLAIN_TEXT`)."""
    import matplotlib

    with matplotlib.rc_context(PLAIN_TEXT):
        yield
