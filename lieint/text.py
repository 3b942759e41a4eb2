"""Text from scenes and files made safe to print on a terminal or in a figure.

A scene's ``name`` or ``description``, a run file's attributes and a store's metadata are
written by whoever wrote the file. Printed raw, ``"\\x1b[2J"`` clears the user's screen and
``"\\x1b]0;…\\x07"`` sets the window title; a newline forges a line of lieint's own output.
:func:`printable` escapes every character that is not printable (control characters,
separators, DEL, C1 codes) as Python writes it in a string literal (``\\x1b``, ``\\n``,
``\\u2028``), and keeps everything else, including non-ASCII letters and symbols.
"""

from __future__ import annotations

__all__ = ["printable"]


def printable(text) -> str:
    """``text`` (a str, or anything ``str()`` takes) with its unprintable characters escaped.

    Examples
    --------
    >>> printable("top\\x1b[2J")
    'top\\\\x1b[2J'
    >>> printable("Ω₁ ≥ 0")
    'Ω₁ ≥ 0'
    """
    text = text if isinstance(text, str) else str(text)
    if text.isprintable():
        return text
    return "".join(ch if ch.isprintable() else ch.encode("unicode_escape").decode("ascii") for ch in text)
