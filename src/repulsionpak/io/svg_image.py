"""``<image>`` elements: an SVG picture drawn as vector art, a raster one approximated.

An ``<image>`` of an SVG picture (a file, ``data:`` URI, gzip-compressed or not) becomes a
nested ``<svg>`` viewport (the image's ``x``, ``y``, ``width``, ``height`` and
``preserveAspectRatio``, the picture's ``viewBox``) holding the picture's content, its
ids prefixed: the reader draws it as the file's own shapes. Images inside that content
are not followed (a picture drawn as an image loads nothing further in browsers).

The package packs vector art; a raster picture has no outline to pack. Rather than leave
it out (a file of images alone was refused as having no geometry), each raster
``<image>`` is replaced before svgelements reads the tree by a ``<rect>``:

* its place is the image's viewport (``x``, ``y``, ``width``, ``height``) with the picture
  fitted in by ``preserveAspectRatio`` (``meet`` leaves bands, ``slice`` is cut at the
  viewport, ``none`` stretches), shrunk to the box of the picture's visible pixels (at
  least a quarter opaque);
* its fill is the mean colour of those pixels;
* ``transform``, ``clip-path``, ``opacity``, ``visibility``, ``display``, ``style``,
  ``class`` and ``id`` are kept.

The picture is read (Pillow) from a ``data:`` URI or a file named relative to the SVG
file (no absolute paths, no URLs, not the file itself). A picture that cannot be read
is left out, as browsers draw nothing for it; the reader names both cases.
"""

from __future__ import annotations

import base64
import gzip
import io
import math
import re
import urllib.parse
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Callable

__all__ = ["images_to_rects"]

_XLINK = "{http://www.w3.org/1999/xlink}href"
#: the largest picture file read (bytes)
MAX_IMAGE_BYTES = 32 * 1024 * 1024
#: how deep pictures inside SVG pictures are followed
MAX_DEPTH = 3
#: pixels at least this opaque are the picture's visible part (a soft shadow's fringe is not)
VISIBLE_ALPHA = 0.25
_KEEP = ("transform", "clip-path", "opacity", "visibility", "display", "style", "class", "id")


def _picture_bytes(href: str, base: Path | None) -> bytes | None:
    """The bytes ``href`` names: a ``data:`` URI, or a file relative to ``base`` (None:
    no files); None when unreadable, remote or too large."""
    if href.startswith("data:"):
        head, _, payload = href.partition(",")
        try:
            return base64.b64decode(re.sub(r"\s+", "", payload)) if ";base64" in head.lower() \
                else urllib.parse.unquote_to_bytes(payload)
        except ValueError:
            return None
    if base is None or "://" in href or href.startswith(("/", "\\")) or not href:
        return None
    f = (base / urllib.parse.unquote(href.split("#", 1)[0])).resolve()
    try:
        if f.is_file() and f.stat().st_size <= MAX_IMAGE_BYTES:
            return f.read_bytes()
    except OSError:
        return None
    return None


def _svg_text(data: bytes) -> str | None:
    """The text of an SVG picture (gzip-compressed or not), None when it is not one."""
    if data[:2] == b"\x1f\x8b":
        try:
            with gzip.GzipFile(fileobj=io.BytesIO(data)) as z:
                data = z.read(MAX_IMAGE_BYTES + 1)
        except (OSError, EOFError):
            return None
        if len(data) > MAX_IMAGE_BYTES:
            return None
    text = data.decode("utf-8", "replace").lstrip("\ufeff \t\r\n")
    return text if text.startswith("<") and "<svg" in text[:4096] else None


def _raster(data: bytes):
    from PIL import Image

    try:
        img = Image.open(io.BytesIO(data))
        img.load()
        return img
    except Exception:  # noqa: BLE001  (any undecodable picture: not drawn, as browsers do)
        return None


def _intrinsic(svg_root: ET.Element, length) -> tuple[float, float, list[float] | None]:
    """An SVG picture's size (its width and height, else its viewBox's, else 100 × 100)
    and its viewBox."""
    try:
        vb = [float(v) for v in re.split(r"[\s,]+", (svg_root.get("viewBox") or "").strip()) if v]
    except ValueError:
        vb = []
    vb = vb if len(vb) == 4 and vb[2] > 0 and vb[3] > 0 else None
    size = []
    for k, i in (("width", 2), ("height", 3)):
        v = svg_root.get(k)
        n = length(v, 100.0) if v and "%" not in v else float("nan")
        size.append(n if math.isfinite(n) and n > 0 else (vb[i] if vb else 100.0))
    return size[0], size[1], vb


def _visible(img):
    """(mean colour "#rrggbb", (x0, y0, x1, y1) box of the visible pixels (alpha at least
    ``VISIBLE_ALPHA``) in the picture's pixels), or None when none is."""
    import numpy as np

    w, h = img.size
    small = img.convert("RGBA")
    if w * h > 256 * 256:  # the colour and the box need no more
        small = small.resize((max(1, round(w * 256 / max(w, h))), max(1, round(h * 256 / max(w, h)))))
    a = np.asarray(small, dtype=float)
    alpha = a[..., 3] / 255.0
    if alpha.max() <= 0:
        return None
    rgb = (a[..., :3] * alpha[..., None]).sum((0, 1)) / alpha.sum()
    ys, xs = np.nonzero(alpha >= VISIBLE_ALPHA)
    if len(xs) == 0:
        return None
    kx, ky = w / small.size[0], h / small.size[1]
    box = (xs.min() * kx, ys.min() * ky, (xs.max() + 1) * kx, (ys.max() + 1) * ky)
    return "#" + "".join(f"{int(round(v)):02x}" for v in rgb), box


def _fit(x, y, w, h, iw, ih, par: str | None):
    """(sx, sy, tx, ty): picture pixels -> user units, and whether the picture is cut
    at the viewport (slice)."""
    words = (par or "xMidYMid meet").replace("defer", "").split()
    align = words[0] if words else "xMidYMid"
    slice_ = len(words) > 1 and words[1] == "slice"
    if align == "none":
        return w / iw, h / ih, x, y
    s = max(w / iw, h / ih) if slice_ else min(w / iw, h / ih)
    fx = {"xMin": 0.0, "xMid": 0.5, "xMax": 1.0}.get(align[:4], 0.5)
    fy = {"YMin": 0.0, "YMid": 0.5, "YMax": 1.0}.get(align[4:], 0.5)
    return s, s, x + fx * (w - s * iw), y + fy * (h - s * ih)


def _prefixed(text: str, prefix: str) -> str:
    """An SVG picture's text with its ids (and the references to them) prefixed, so that
    they cannot collide with the file's."""
    text = re.sub(r"""(\bid\s*=\s*["'])""", r"\1" + prefix, text)
    text = re.sub(r"url\(\s*(['\"]?)#", lambda m: f"url({m.group(1)}#{prefix}", text)
    return re.sub(r"""(href\s*=\s*["'])#""", r"\1#" + prefix, text)


def images_to_rects(root: ET.Element, base: Path | None, length: Callable[[str, float], float],
                    reference: tuple[float, float], parse: Callable[[bytes], ET.Element]) -> dict[str, int]:
    """Replace every ``<image>`` under ``root``, in place: an SVG picture by a nested
    ``<svg>`` holding its content (drawn as the file's own shapes), a raster picture by
    the ``<rect>`` of the module docstring; a picture that cannot be read is left out.
    Inside an SVG picture only ``data:`` pictures are drawn (browsers load no files for
    it), ``MAX_DEPTH`` levels deep. ``base``: the SVG file's folder;
    ``length(value, percent_of)``: a length in user units; ``parse(bytes)``: the
    hardened XML parser. Returns the counts ``{"svg": n, "raster": n, "unread": n}``."""
    counts = {"svg": 0, "raster": 0, "unread": 0}
    done: set = set()
    for depth in range(MAX_DEPTH + 1):
        images = [el for el in root.iter() if isinstance(el.tag, str) and el.tag.rsplit("}", 1)[-1] == "image"
                  and id(el) not in done]
        if not images:
            break
        done.update(id(el) for el in images)
        if depth == MAX_DEPTH:  # pictures in pictures in ...: left out
            for el in images:
                _remove(root, el)
            counts["unread"] += len(images)
            break
        _replace(root, images, base if depth == 0 else None, length, reference, parse, counts, depth)
    return counts


def _remove(root: ET.Element, el: ET.Element) -> None:
    for p in root.iter():
        if el in list(p):
            p.remove(el)
            return


def _replace(root, images, base, length, reference, parse, counts, depth) -> None:
    parent = {c: p for p in root.iter() for c in p}
    for k, el in enumerate(images):
        holder = parent.get(el)
        if holder is None:
            continue
        anc, in_clip = holder, False
        while anc is not None:  # an image is no child of a clipPath: it never clips
            in_clip = in_clip or anc.tag.rsplit("}", 1)[-1] == "clipPath"
            anc = parent.get(anc)
        i = list(holder).index(el)
        holder.remove(el)
        if in_clip:
            continue
        href = (el.get(_XLINK) or el.get("href") or "").strip()
        data = _picture_bytes(href, base) if href else None
        text = _svg_text(data) if data else None
        picture, img = None, None
        if text is not None:
            try:
                picture = parse(_prefixed(text, f"repulsionpak-image{depth}-{k}-").encode("utf-8"))
            except Exception:  # noqa: BLE001  (a picture that cannot be parsed is not drawn)
                picture = None
            if picture is not None and picture.tag.rsplit("}", 1)[-1] != "svg":
                picture = None
            if picture is not None:
                iw, ih, vb = _intrinsic(picture, length)
        elif data is not None:
            img = _raster(data)
            if img is not None:
                iw, ih = (float(v) for v in img.size)
        if picture is None and img is None:
            counts["unread"] += 1
            continue
        x = length(el.get("x") or "0", reference[0])
        y = length(el.get("y") or "0", reference[1])
        auto = [v is None or v.strip() == "auto" for v in (el.get("width"), el.get("height"))]
        w = None if auto[0] else length(el.get("width"), reference[0])
        h = None if auto[1] else length(el.get("height"), reference[1])
        if w is None and h is None:
            w, h = iw, ih
        elif w is None:
            w = h * iw / ih
        elif h is None:
            h = w * ih / iw
        if not all(math.isfinite(v) for v in (x, y, w, h)) or not (w > 0 and h > 0):
            continue
        ns = el.tag[:el.tag.index("}") + 1] if el.tag.startswith("{") else ""
        keep = {a: el.get(a) for a in _KEEP if el.get(a) is not None}
        if picture is not None:
            counts["svg"] += 1
            g = ET.Element(ns + "g", keep)
            svg = ET.SubElement(g, ns + "svg", {
                "x": repr(x), "y": repr(y), "width": repr(w), "height": repr(h),
                "viewBox": " ".join(repr(float(v)) for v in (vb or (0.0, 0.0, iw, ih))),
                "preserveAspectRatio": el.get("preserveAspectRatio") or "xMidYMid meet"})
            for a in ("fill", "stroke", "style", "font-family", "font-size"):
                if picture.get(a) is not None and a not in svg.attrib:
                    svg.set(a, picture.get(a))
            for c in list(picture):
                svg.append(c)
            g.tail = el.tail
            holder.insert(i, g)
            continue
        counts["raster"] += 1
        seen = _visible(img)
        if seen is None:
            continue  # a fully transparent picture draws nothing
        colour, (bx0, by0, bx1, by1) = seen
        sx, sy, tx, ty = _fit(x, y, w, h, iw, ih, el.get("preserveAspectRatio"))
        box = (max(x, tx + sx * bx0), max(y, ty + sy * by0), min(x + w, tx + sx * bx1), min(y + h, ty + sy * by1))
        if not (box[2] > box[0] and box[3] > box[1]):
            continue
        rect = ET.Element(ns + "rect", keep)
        rect.set("x", repr(float(box[0])))
        rect.set("y", repr(float(box[1])))
        rect.set("width", repr(float(box[2] - box[0])))
        rect.set("height", repr(float(box[3] - box[1])))
        rect.set("fill", colour)
        rect.set("stroke", "none")
        rect.tail = el.tail
        holder.insert(i, rect)
