"""Small helpers on the parsed XML of an SVG file, shared by the reader's modules."""

from __future__ import annotations

import re

_IMPORTANT = re.compile(r"\s*!\s*important\s*$", re.IGNORECASE)


def local_name(tag) -> str:
    """An element's tag without its namespace ("" for comments and processing instructions)."""
    if not isinstance(tag, str):
        return ""
    return tag.rsplit("}", 1)[-1] if tag.startswith("{") else tag


def inline_declarations(style: str | None) -> list[tuple[str, str, bool]]:
    """``(property, value, important)`` of a ``style`` attribute, in order."""
    out = []
    for part in (style or "").split(";"):
        name, sep, value = part.partition(":")
        name = name.strip().lower()
        if not sep or not name:
            continue
        important = bool(_IMPORTANT.search(value))
        out.append((name, _IMPORTANT.sub("", value).strip(), important))
    return out
