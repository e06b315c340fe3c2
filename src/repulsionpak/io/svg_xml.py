"""Small helpers on the parsed XML of an SVG file, shared by the reader's modules."""

from __future__ import annotations

import re

#: attribute marking the groups that hold a text's glyph outlines (its value: text, tspan ...):
#: a clipPath takes text, but no groups
TEXT_GROUP = "data-repulsionpak-text"

SVG_NS = "http://www.w3.org/2000/svg"
XLINK_NS = "http://www.w3.org/1999/xlink"

_IMPORTANT = re.compile(r"\s*!\s*important\s*$", re.IGNORECASE)


def local_name(tag) -> str:
    """An element's tag without its namespace ("" for comments and processing instructions)."""
    if not isinstance(tag, str):
        return ""
    return tag.rsplit("}", 1)[-1] if tag.startswith("{") else tag


def sprite_hint(root) -> str:
    """The end of a "draws nothing" error for a file that defines ``<symbol>``s and draws
    none (an icon set's sprite sheet: a page draws its icons with ``<use>``): give the
    icons one by one. Empty for any other file (or no tree).

    Parameters
    ----------
    root : ElementTree element or None
        The parsed file.

    Returns
    -------
    str
        ``"; it defines N <symbol>s ..."``, or ``""``.
    """
    if root is None:
        return ""
    n = sum(1 for e in root.iter() if local_name(e.tag) == "symbol")
    if not n:
        return ""
    return (f"; it defines {n:,} <symbol>{'s' if n > 1 else ''} and draws none of them (a sprite sheet): "
            "give each icon as a file of its own, or draw the one wanted with a <use>")


def href(el) -> str | None:
    """An element's ``href`` (``xlink:href`` first, as SVG 1.1 files write it), or None."""
    return el.get(f"{{{XLINK_NS}}}href") or el.get("href")


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


def drop_use_cycles(root, href) -> int:
    """Remove every ``<use>`` that would draw itself (its reference leads back to an
    element the use lies in, directly or through other uses), as browsers skip only that
    use and draw the rest; ``href(el)`` gives a use's reference. Returns how many went."""
    ids = {el.get("id"): el for el in root.iter() if isinstance(el.tag, str) and el.get("id")}
    parent = {c: p for p in root.iter() for c in p}
    bad: list = []
    done: set[int] = set()

    def visit(el, active: set[int]) -> None:
        # ``active``: elements being expanded on this path (ancestors and use targets)
        if id(el) in done:  # expanded before: its cycles, if any, are already cut
            return
        active.add(id(el))
        for c in list(el):
            if isinstance(c.tag, str):
                visit(c, active)
        if local_name(el.tag) == "use":
            ref = (href(el) or "").strip()
            target = ids.get(ref[1:]) if ref.startswith("#") else None
            if target is not None:
                if id(target) in active:
                    bad.append(el)
                else:
                    visit(target, active)
        active.discard(id(el))
        done.add(id(el))

    visit(root, set())
    for el in bad:
        p = parent.get(el)
        if p is not None and el in list(p):
            p.remove(el)
    return len(bad)


_PAINT_PROPS = ("fill", "stroke", "color", "stop-color", "flood-color", "lighting-color")
_RGB = re.compile(r"(rgba?)\(\s*([^()]*?)\s*\)", re.IGNORECASE)
_RGB_NUMBER = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?%?")


def _rounded_rgb(m: re.Match) -> str:
    parts = [p.strip() for p in m.group(2).split(",")]
    if len(parts) not in (3, 4) or not all(_RGB_NUMBER.fullmatch(p) for p in parts):
        return m.group(0)
    chans = []
    for p in parts[:3]:
        v = float(p[:-1]) * 2.55 if p.endswith("%") else float(p)
        chans.append(str(int(min(255.0, max(0.0, v)) + 0.5)))  # CSS: clamp, round half up
    alpha = f",{parts[3]}" if len(parts) == 4 else ""
    return f"{m.group(1).lower()}({','.join(chans)}{alpha})"


def integer_rgb_colours(root) -> None:
    """``rgb()`` colours with fractional channels (``rgb(0.8, 127.5, 14.2)``, valid CSS)
    rounded to integers in paint attributes and ``style`` (svgelements raised on them and
    left the shape unpainted)."""
    for el in root.iter():
        if not isinstance(el.tag, str):
            continue
        for name in _PAINT_PROPS:
            v = el.get(name)
            if v and "." in v and "rgb" in v.lower():
                el.set(name, _RGB.sub(_rounded_rgb, v))
        style = el.get("style")
        if style and "." in style and "rgb" in style.lower():
            el.set("style", _RGB.sub(_rounded_rgb, style))
