"""Gradients and patterns of placed copies: transformed with the copy, ids made unique.

The art of a copy is written in container coordinates, so every paint server it uses is
re-expressed there: ``objectBoundingBox`` units are resolved with the source shape's
bounding box, and ``gradientTransform``/``patternTransform`` become the copy's affine
approximation (least-squares fit of its deformed mesh) ∘ the source shape's transform ∘
the original transform. Every id inside a copied server gets the copy's suffix and the
references between copied servers are rewritten.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET

import numpy as np

__all__ = ["CopyPaint", "matrix_attr"]

_URL = re.compile(r"url\(\s*['\"]?#([^)'\"]+)['\"]?\s*\)")
_GRAD_LEN = {"x1", "y1", "x2", "y2", "cx", "cy", "r", "fx", "fy", "fr"}


def matrix_attr(m: np.ndarray) -> str:
    """SVG ``matrix(a b c d e f)`` of a (3, 3) affine matrix."""
    a, c, e = m[0]
    b, d, f = m[1]
    return "matrix(" + " ".join(format(float(v), ".8g") for v in (a, b, c, d, e, f)) + ")"


def _parse_transform(text: str | None) -> np.ndarray:
    if not text or not text.strip():
        return np.eye(3)
    import svgelements as se

    try:
        m = se.Matrix(text)
    except Exception:
        return np.eye(3)
    return np.array([[m.a, m.c, m.e], [m.b, m.d, m.f], [0.0, 0.0, 1.0]])


def _fraction(v: str | None, default: float) -> float:
    """A bbox-relative length: ``"50%"`` or ``"0.5"`` -> 0.5."""
    if v is None or not str(v).strip():
        return default
    s = str(v).strip()
    try:
        return float(s[:-1]) / 100.0 if s.endswith("%") else float(s)
    except ValueError:
        return default


def _fmt(x: float) -> str:
    return format(float(x), ".8g")


def _place_gradient(el: ET.Element, m: np.ndarray, bbox) -> bool:
    """Rewrite gradient ``el`` in place for the copy matrix ``m``; False if unusable."""
    units = (el.get("gradientUnits") or "objectBoundingBox").strip()
    g = _parse_transform(el.get("gradientTransform"))
    if units != "userSpaceOnUse":
        if bbox is None:
            return False
        x0, y0, x1, y1 = bbox
        w, h = x1 - x0, y1 - y0
        if not (w > 0 and h > 0):
            return False
        b = np.array([[w, 0.0, x0], [0.0, h, y0], [0.0, 0.0, 1.0]])
        g = b @ g
        linear = el.tag == "linearGradient"
        defaults = ({"x1": 0.0, "y1": 0.0, "x2": 1.0, "y2": 0.0} if linear
                    else {"cx": 0.5, "cy": 0.5, "r": 0.5})
        for k, d in defaults.items():
            el.set(k, _fmt(_fraction(el.get(k), d)))
        if not linear:
            for k, ref in (("fx", "cx"), ("fy", "cy")):
                el.set(k, _fmt(_fraction(el.get(k), float(el.get(ref)))))
            if el.get("fr") is not None:
                el.set("fr", _fmt(_fraction(el.get("fr"), 0.0)))
        el.set("gradientUnits", "userSpaceOnUse")
    el.set("gradientTransform", matrix_attr(m @ g))
    return True


def _place_pattern(el: ET.Element, m: np.ndarray, bbox) -> bool:
    units = (el.get("patternUnits") or "objectBoundingBox").strip()
    content = (el.get("patternContentUnits") or "userSpaceOnUse").strip()
    if bbox is not None:
        x0, y0, x1, y1 = bbox
        w, h = x1 - x0, y1 - y0
    else:
        x0 = y0 = w = h = None
    if units != "userSpaceOnUse":
        if bbox is None or not (w > 0 and h > 0):
            return False
        el.set("x", _fmt(x0 + w * _fraction(el.get("x"), 0.0)))
        el.set("y", _fmt(y0 + h * _fraction(el.get("y"), 0.0)))
        el.set("width", _fmt(w * _fraction(el.get("width"), 0.0)))
        el.set("height", _fmt(h * _fraction(el.get("height"), 0.0)))
        el.set("patternUnits", "userSpaceOnUse")
    if content == "objectBoundingBox" and el.get("viewBox") is None:
        if bbox is None or not (w > 0 and h > 0):
            return False
        g = ET.Element("g", {"transform": f"matrix({_fmt(w)} 0 0 {_fmt(h)} 0 0)"})
        for child in list(el):
            el.remove(child)
            g.append(child)
        el.append(g)
    el.attrib.pop("patternContentUnits", None)
    el.set("patternTransform", matrix_attr(m @ _parse_transform(el.get("patternTransform"))))
    return True


def _rewrite_refs(el: ET.Element, rename: dict[str, str]) -> None:
    def sub(text: str) -> str:
        return _URL.sub(lambda mo: f"url(#{rename.get(mo.group(1), mo.group(1))})", text)

    for e in el.iter():
        for k, v in list(e.attrib.items()):
            if k == "href" and v.startswith("#") and v[1:] in rename:
                e.set(k, "#" + rename[v[1:]])
            elif "url(" in v:
                e.set(k, sub(v))


class CopyPaint:
    """The paint servers of one written copy.

    ``servers``: the element's ``{id: markup}``; ``suffix``: appended to every id of
    this copy (e.g. ``"-e12"``). :meth:`paint` returns the paint attribute value for a
    shape (a ``url(#...)`` of a server transformed for that shape, or None when the
    server is unusable and the fallback colour must be used); :meth:`defs` the markup
    to write in the copy's ``<defs>``.
    """

    def __init__(self, servers: dict, suffix: str):
        self.servers = servers or {}
        self.suffix = suffix
        self._made: dict[tuple, str] = {}
        self._markup: list[str] = []
        self._nested: set[str] = set()

    def _copy(self, key: str, new_id: str, m: np.ndarray | None, bbox) -> bool:
        el = ET.fromstring(self.servers[key])
        if m is not None:
            ok = (_place_pattern(el, m, bbox) if el.tag == "pattern"
                  else _place_gradient(el, m, bbox))
            if not ok:
                return False
        rename = {}
        for e in el.iter():
            i = e.get("id")
            if i is not None and e is not el:
                rename[i] = i + self.suffix
                e.set("id", rename[i])
        el.set("id", new_id)
        nested = set()
        for e in el.iter():
            for v in e.attrib.values():
                nested.update(x for x in _URL.findall(v) if x in self.servers)
        rename.update({x: x + self.suffix + "-in" for x in nested})
        _rewrite_refs(el, rename)
        self._markup.append(ET.tostring(el, encoding="unicode"))
        for x in nested - self._nested:  # servers used inside patterns: renamed, not moved
            self._nested.add(x)
            self._copy(x, x + self.suffix + "-in", None, None)
        return True

    def paint(self, server_id: str | None, matrix: np.ndarray, bbox) -> str | None:
        if not server_id or server_id not in self.servers:
            return None
        key = (server_id, tuple(np.round(np.asarray(matrix, float).ravel(), 9)),
               None if bbox is None else tuple(np.round(bbox, 9)))
        if key not in self._made:
            n = sum(1 for k in self._made if k[0] == server_id)
            new_id = f"{server_id}{self.suffix}" + (f"-{n}" if n else "")
            if not self._copy(server_id, new_id, np.asarray(matrix, float), bbox):
                return None
            self._made[key] = new_id
        return f"url(#{self._made[key]})"

    def defs(self) -> list[str]:
        return list(self._markup)
