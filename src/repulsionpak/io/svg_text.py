"""``<text>`` drawn as glyph outlines, so that lettering packs like any other art.

Design tools write lettering as ``<text>`` unless told to convert it to outlines, and
svgelements alone finds no visible geometry in a text-only element. Before svgelements reads a
file, every ``<text>`` becomes a ``<g>`` with the text's own attributes (fill, stroke,
class, style, transform, clip-path, id ...) holding one ``<path>`` of glyph outlines per
run of characters; each ``<tspan>`` (and ``<a>``, ``<textPath>``) becomes a nested ``<g>``
with its attributes, so colours and strokes cascade as they did.

The outlines come from matplotlib's font machinery (FreeType, the fonts matplotlib finds:
its own DejaVu and STIX families and the system's), laid out as browsers lay out a line:
``x``/``y`` (first values), ``dx``/``dy``, ``text-anchor`` per text chunk, kerning,
``font-family`` (a list, with the generic families), ``font-size`` (px, pt, pc, mm, cm, in,
em, %, keywords), ``font-weight``, ``font-style``, the ``font`` shorthand, and
``xml:space``. Not supported, with a warning: per-character position lists, ``rotate``,
``letter-spacing``/``word-spacing``, ``textLength``, text along a path (drawn on a straight
line), vertical writing. A family that is not installed falls back to the default serif
font, as in browsers, with a warning naming it: the copies then show that font, not the
one the file asks for.
"""

from __future__ import annotations

import logging
import re
import warnings
import xml.etree.ElementTree as ET

import numpy as np

from .svg_lengths import FONT_SIZE_KEYWORDS as _SIZE_KEYWORDS
from .svg_lengths import font_size_value
from .svg_text_metrics import BASELINES, baseline_offset, decoration_bars, metrics_of, shift_item
from .svg_xml import TEXT_GROUP, inline_declarations
from .svg_xml import local_name as _local

__all__ = ["text_to_paths"]

_TEXT_LIKE = {"tspan", "a", "textPath"}
_POSITION_ATTRS = ("x", "y", "dx", "dy", "rotate", "textLength", "lengthAdjust")
_XML_SPACE = "{http://www.w3.org/XML/1998/namespace}space"
_GENERIC = {"serif", "sans-serif", "monospace", "cursive", "fantasy"}
_UNITS = {"": 1.0, "px": 1.0, "pt": 4.0 / 3.0, "pc": 16.0, "mm": 96.0 / 25.4, "cm": 96.0 / 2.54,
          "in": 96.0, "q": 96.0 / 101.6}
_DEFAULT_SIZE = 16.0  # a browser's "medium"
_NUMBER = r"[+-]?(?:\d+\.?\d*|\.\d+)(?:e[+-]?\d+)?"


def _split_families(text: str) -> list[str]:
    return [f.strip().strip("'\"").strip() for f in text.split(",") if f.strip().strip("'\"").strip()]


def _shorthand(value: str) -> dict[str, str]:
    """The ``font`` shorthand: [style] [variant] [weight] [stretch] size[/line-height] family."""
    tokens = re.findall(r"'[^']*'|\"[^\"]*\"|[^\s]+", value)
    for i, tok in enumerate(tokens):
        size = tok.split("/", 1)[0]
        if re.fullmatch(_NUMBER + r"[a-zA-Z%]*", size, re.IGNORECASE) or size.lower() in _SIZE_KEYWORDS:
            out = {"font-size": size, "font-family": " ".join(tokens[i + 1:])}
            for t in tokens[:i]:
                t = t.lower()
                if t in ("italic", "oblique"):
                    out["font-style"] = t
                elif t in ("bold", "bolder", "lighter") or re.fullmatch(r"\d{3}", t):
                    out["font-weight"] = t
                elif t == "small-caps":
                    out["font-variant"] = t
                elif t.endswith(("condensed", "expanded")):
                    out["font-stretch"] = t
            return out
    return {}


class _Props:
    """Computed font properties of one element (inherited down the text's tree)."""

    def __init__(self, parent: "_Props | None", el: ET.Element | None):
        own: dict[str, str] = {}
        if el is not None:
            for name in ("font-family", "font-size", "font-weight", "font-style", "text-anchor",
                         "letter-spacing", "word-spacing", "writing-mode", "font-variation-settings",
                         "font-variant", "font-stretch", "dominant-baseline", "alignment-baseline",
                         "baseline-shift", "text-decoration"):
                if el.get(name) is not None:
                    own[name] = el.get(name).strip()
            decls = {k: v for k, v, _ in inline_declarations(el.get("style"))}
            if "font" in decls:
                own.update(_shorthand(decls["font"]))
            own.update({k: v for k, v in decls.items() if k.startswith(("font-", "text-anchor", "letter-",
                                                                         "word-", "writing-", "dominant-",
                                                                         "alignment-", "baseline-",
                                                                         "text-decoration"))})
        base = parent
        self.size = base.size if base else _DEFAULT_SIZE
        self.family = base.family if base else ["serif"]  # browsers' default font
        self.weight = base.weight if base else 400
        self.style = base.style if base else "normal"
        self.anchor = base.anchor if base else "start"
        self.dominant = base.dominant if base else "auto"  # inherited
        self.alignment = "auto"  # not inherited
        # baseline-shift: not inherited, but the shifts of nested tspans add up (the <text>'s own
        # is not applied, as in Chrome and resvg)
        tspan = el is not None and _local(el.tag) in _TEXT_LIKE
        self.shifts = base.shifts if base and tspan else ()
        # (kind, the declaring element's props): drawn across every descendant's text in the
        # declaring element's paint
        self.decorations = base.decorations if base else ()
        self.target = None  # the group of this element's glyphs (set by _layout)
        # what is not supported is said wherever it is set (on a group around the text too)
        self.unsupported: set[str] = set(base.unsupported) if base else set()
        for name, v in own.items():
            if v.lower() == "inherit":
                if name == "alignment-baseline":  # not inherited unless asked
                    self.alignment = base.alignment if base else "auto"
                continue
            if name == "dominant-baseline" and v.lower() in BASELINES:
                self.dominant = self.dominant if v.lower() == "no-change" else v.lower()
            elif name == "alignment-baseline" and v.lower() in BASELINES:
                self.alignment = v.lower()
            elif name == "text-decoration":
                kinds = tuple(k for k in v.lower().split() if k in ("underline", "overline", "line-through"))
                self.decorations = self.decorations + tuple((k, self) for k in dict.fromkeys(kinds))
            if name == "font-size":
                self.size = _font_size(v, self.size)
            elif name == "font-family":
                self.family = _split_families(v) or self.family
            elif name == "font-weight":
                self.weight = _weight(v, self.weight)
            elif name == "font-style":
                self.style = "italic" if v.lower() in ("italic", "oblique") or v.lower().startswith("oblique") \
                    else "normal"
            elif name == "text-anchor":
                self.anchor = v.lower() if v.lower() in ("start", "middle", "end") else self.anchor
            elif name in ("letter-spacing", "word-spacing") and v.lower() not in ("normal", "0", "0px"):
                self.unsupported.add(name)
            elif name in ("font-variation-settings", "font-variant", "font-stretch") and v.lower() not in (
                    "normal", "none", "initial"):
                self.unsupported.add(name)
            elif name == "writing-mode" and v.lower() not in ("horizontal-tb", "lr", "lr-tb", "rl", "rl-tb"):
                self.unsupported.add("vertical writing")
        if tspan and own.get("baseline-shift") is not None:
            item = shift_item(own["baseline-shift"], self.size)
            if item is not None:
                self.shifts = self.shifts + (item,)


def _font_size(v: str, parent: float) -> float:
    size = font_size_value(v, parent)
    return size if size > 0 else parent  # a zero size draws no glyph: keep the text visible


def _weight(v: str, parent: int) -> int:
    """CSS ``font-weight`` as a number 1-1000 (``bolder``/``lighter`` relative to the
    parent's, as CSS Fonts 4 has them); matplotlib picks the installed face nearest it."""
    v = v.strip().lower()
    if v == "normal":
        return 400
    if v == "bold":
        return 700
    if v == "bolder":
        return 400 if parent < 350 else 700 if parent < 550 else 900
    if v == "lighter":
        return 100 if parent < 550 else 400 if parent < 750 else 700
    try:
        w = float(v)
    except ValueError:
        return parent
    return int(round(w)) if 1 <= w <= 1000 else parent


def _first_length(el: ET.Element, name: str) -> float | None:
    v = el.get(name)
    if not v:
        return None
    parts = [p for p in re.split(r"[\s,]+", v.strip()) if p]
    if not parts:
        return None
    m = re.fullmatch(rf"({_NUMBER})\s*([a-z]*)", parts[0].lower())
    if not m:
        return None
    return float(m.group(1)) * _UNITS.get(m.group(2), 1.0)


class _Fonts:
    """matplotlib fonts by (families, weight, style), and the families it lacks."""

    def __init__(self):
        from matplotlib.font_manager import FontProperties, findfont
        from matplotlib.textpath import TextToPath

        self._fp, self._findfont = FontProperties, findfont
        self._ttp = TextToPath()
        self.missing: set[str] = set()
        self.missing_glyphs: set[str] = set()
        self.fallback = "DejaVu Serif"
        self._cache: dict = {}
        self._names = None

    def _installed(self, family: str) -> bool:
        if self._names is None:
            from matplotlib.font_manager import fontManager

            self._names = {f.name.lower() for f in fontManager.ttflist}
        return family.lower() in self._names

    def prop(self, props: _Props):
        key = (tuple(props.family), props.weight, props.style)
        if key not in self._cache:
            from matplotlib.font_manager import get_font

            families = list(props.family)
            named = [f for f in families if f.lower() not in _GENERIC]
            installed = [f for f in named if self._installed(f)]
            if named and not installed:
                self.missing.add(named[0])
            # a family that is not installed falls back to the browsers' default, serif
            # (Chrome's and resvg's "Times New Roman"), not to matplotlib's sans-serif
            use = installed + [f for f in families if f.lower() in _GENERIC] or ["serif"]
            fp = self._fp(family=use, weight=props.weight, style=props.style, size=self._ttp.FONT_SCALE)
            if named and not installed:  # the font the warning names
                self.fallback = get_font(self._findfont(fp, fallback_to_default=True)).family_name
            self._cache[key] = fp
        return self._cache[key]

    def metrics(self, props: _Props):
        """The :class:`~.svg_text_metrics.FontMetrics` of the face ``props`` draws with."""
        fp = self.prop(props)
        key = ("metrics", id(fp))
        if key not in self._cache:
            self._cache[key] = metrics_of(self._ttp._get_font(fp))
        return self._cache[key]

    def run(self, s: str, props: _Props) -> tuple[np.ndarray, np.ndarray, float]:
        """Glyph outline of ``s`` (vertices with y down, baseline at 0, pen at 0; path
        codes) and its advance, at ``props.size``."""
        from matplotlib.ft2font import LoadFlags
        from matplotlib.textpath import TextPath

        fp = self.prop(props)
        scale = props.size / self._ttp.FONT_SCALE
        with warnings.catch_warnings(record=True) as caught:  # "Glyph N (...) missing from font(s) ..."
            warnings.simplefilter("always")
            font = self._ttp._get_font(fp)
            glyphs = self._ttp.get_glyphs_with_font(font, s, return_new_glyphs_only=False)[0]
            glyph = font.load_char(ord(s[-1]), flags=LoadFlags.NO_HINTING) if glyphs else None
            # a run of spaces has no outline (matplotlib's TextPath cannot be built for it):
            # only its advance moves the pen
            tp = TextPath((0, 0), s, size=props.size, prop=fp) if s.strip() else None
        for w in caught:
            m = re.match(r"Glyph (\d+) ", str(w.message))
            if m:
                self.missing_glyphs.add(chr(int(m.group(1))))
            else:
                warnings.warn(w.message, w.category, stacklevel=2)
        if tp is None:
            verts, codes = np.zeros((0, 2)), np.zeros(0, dtype=np.uint8)
        else:
            verts, codes = np.array(tp.vertices, dtype=float), np.asarray(tp.codes)
            verts[:, 1] = -verts[:, 1]
        if glyph is None:
            return verts, codes, 0.0
        return verts, codes, (glyphs[-1][1] + glyph.linearHoriAdvance / 65536.0) * scale


def _path_data(verts: np.ndarray, codes: np.ndarray) -> str:
    out, i, n = [], 0, len(codes)
    f = lambda p: f"{p[0]:.6g} {p[1]:.6g}"  # noqa: E731
    while i < n:
        c = codes[i]
        if c == 1:
            out.append("M" + f(verts[i]))
            i += 1
        elif c == 2:
            out.append("L" + f(verts[i]))
            i += 1
        elif c == 3:
            out.append("Q" + f(verts[i]) + " " + f(verts[i + 1]))
            i += 2
        elif c == 4:
            out.append("C" + f(verts[i]) + " " + f(verts[i + 1]) + " " + f(verts[i + 2]))
            i += 3
        elif c == 79:
            out.append("Z")
            i += 1
        else:  # STOP
            i += 1
    return "".join(out)


def _collapse(s: str, preserve: bool) -> str:
    if preserve:
        return s.replace("\n", " ").replace("\r", " ").replace("\t", " ")
    return re.sub(r" +", " ", s.replace("\r", "").replace("\n", "").replace("\t", " "))


def _display_none(el: ET.Element) -> bool:
    value = el.get("display")
    for decl in str(el.get("style") or "").split(";"):
        k, _, v = decl.partition(":")
        if k.strip().lower() == "display":
            value = v
    return str(value or "").strip().lower() == "none"


#: elements of SVG (what a tref may take its characters from; an unknown one is not)
_SVG_ELEMENTS = frozenset(
    "a circle clipPath defs desc ellipse feBlend filter g image line linearGradient marker mask "
    "metadata path pattern polygon polyline radialGradient rect stop style svg switch symbol text "
    "textPath title tspan use view".split())


def _trefs_to_tspans(root: ET.Element) -> None:
    """``<tref xlink:href="#id">`` (SVG 1.1) as the ``<tspan>`` it stands for: the
    character data of the referenced element, the tref's own attributes; a tref naming
    nothing draws nothing."""
    ids = {e.get("id"): e for e in root.iter() if isinstance(e.tag, str) and e.get("id")}
    trefs = [el for el in root.iter() if isinstance(el.tag, str) and _local(el.tag) == "tref"]

    def chars(el) -> str:  # character data, a nested tref's excluded (not followed)
        out = [el.text or ""]
        for c in el:
            if not (isinstance(c.tag, str) and _local(c.tag) == "tref"):
                out.append(chars(c))
            out.append(c.tail or "")
        return "".join(out)

    texts = []
    for el in trefs:
        href = (el.get("{http://www.w3.org/1999/xlink}href") or el.get("href") or "").strip()
        target = ids.get(href[1:]) if href.startswith("#") else None
        same_ns = target is not None and isinstance(target.tag, str) and \
            target.tag.rpartition("}")[0] == el.tag.rpartition("}")[0] and _local(target.tag) in _SVG_ELEMENTS
        texts.append(chars(target) if same_ns and target is not el else "")
    for el, text in zip(trefs, texts):
        for c in list(el):
            el.remove(c)
        el.text = text
        el.tag = el.tag[:-len("tref")] + "tspan"


def text_to_paths(root: ET.Element, notes: set[str]) -> str | None:
    """Replace every ``<text>`` under ``root`` by a ``<g>`` of glyph-outline ``<path>``s
    (see the module docstring); what is not supported is added to ``notes``. Returns a
    warning naming the font families that are not installed, if any."""
    _trefs_to_tspans(root)
    texts = [el for el in root.iter() if _local(el.tag) == "text"]
    if not texts:
        return None
    logger = logging.getLogger("matplotlib.font_manager")
    level = logger.level
    logger.setLevel(logging.ERROR)  # "findfont: Font family ... not found": said once, below
    try:
        return _convert(root, texts, notes)
    finally:
        logger.setLevel(level)


def _convert(root: ET.Element, texts: list[ET.Element], notes: set[str]) -> str | None:
    parent = {c: p for p in root.iter() for c in p}
    fonts = _Fonts()
    for text in texts:
        holder = parent.get(text)
        if holder is None:
            continue
        ns = text.tag[:text.tag.index("}") + 1] if text.tag.startswith("{") else ""
        chain, p = [], parent.get(text)
        while p is not None:  # font properties inherited from the groups around the text
            chain.append(p)
            p = parent.get(p)
        props = None
        for anc in reversed(chain):
            props = _Props(props, anc)
        group = _as_group(text, ns)
        pieces: list[dict] = []  # text chunks: anchor, start and end x, [(target, verts, codes)]
        state = {"x": 0.0, "y": 0.0, "first": True}
        _layout(text, group, _Props(props, text), ns, fonts, pieces, state, notes,
                text.get(_XML_SPACE) == "preserve")
        for chunk in pieces:
            # the text's trailing space is not laid out (a space inside it, before the next
            # chunk, is): the anchor of the last chunk sees it without
            end = chunk.get("trimmed", chunk["end"]) if chunk is pieces[-1] else chunk["end"]
            width = 0.0 if chunk["start"] is None else end - chunk["start"]
            shift = {"start": 0.0, "middle": -0.5 * width, "end": -width}[chunk["anchor"]]
            for target, verts, codes in chunk["items"]:
                v = verts.copy()
                v[:, 0] += shift
                d = _path_data(v, codes)
                if d:
                    ET.SubElement(target, ns + "path", {"d": d})
        holder[list(holder).index(text)] = group
    said = []
    if fonts.missing:
        said.append(f"text in a font that is not installed ({', '.join(sorted(fonts.missing))}) is drawn in "
                    f"the default serif font ({fonts.fallback}) instead")
    if fonts.missing_glyphs:
        said.append(f"characters the font lacks ({''.join(sorted(fonts.missing_glyphs))}) are drawn as empty boxes")
    if not said:
        return None
    return "; ".join(said) + "; install the font or convert the text to outlines to pack the lettering as designed"


def _as_group(el: ET.Element, ns: str) -> ET.Element:
    attrs = {k: v for k, v in el.attrib.items() if k not in _POSITION_ATTRS}
    if _local(el.tag) != "text":  # a tspan is not transformable: its transform has no effect
        attrs.pop("transform", None)
    if _local(el.tag) == "text":  # markers are not drawn on text: not on the glyph outlines either
        if "style" in attrs:
            attrs["style"] = ";".join(d for d in attrs["style"].split(";")
                                      if not d.split(":")[0].strip().lower().startswith("marker"))
        attrs.update({k: "none" for k in ("marker-start", "marker-mid", "marker-end")})
    g = ET.Element(ns + "g", attrs)
    g.set(TEXT_GROUP, _local(el.tag))  # (a clipPath takes text, not groups)
    g.tail = el.tail if _local(el.tag) == "text" else None
    return g


def _layout(el, target, props: _Props, ns, fonts: _Fonts, pieces, state, notes, preserve) -> None:
    props.target = target
    for name in props.unsupported:
        notes.add(f"text {name} (ignored)")
    for name in ("rotate", "textLength"):
        if el.get(name):
            notes.add(f"text {name} (ignored)")
    for name in ("x", "y", "dx", "dy"):
        v = el.get(name)
        if v and len([p for p in re.split(r"[\s,]+", v.strip()) if p]) > 1:
            notes.add("text with a position per character (the first one used)")
    x, y = _first_length(el, "x"), _first_length(el, "y")
    if x is not None or y is not None or not pieces:
        state["x"] = x if x is not None else state["x"]
        state["y"] = y if y is not None else state["y"]
        pieces.append({"anchor": props.anchor, "start": None, "end": 0.0, "items": []})
    state["x"] += _first_length(el, "dx") or 0.0
    state["y"] += _first_length(el, "dy") or 0.0
    if _local(el.tag) == "textPath":
        notes.add("text along a path (drawn on a straight line)")
    _emit(el.text, target, props, fonts, pieces, state, preserve, notes)
    for child in el:
        name = _local(child.tag)
        foreign = isinstance(child.tag, str) and child.tag.rpartition("}")[0] != el.tag.rpartition("}")[0]
        if name in _TEXT_LIKE and (foreign or _display_none(child)):  # neither drawn nor advancing
            pass
        elif name in _TEXT_LIKE:
            sub = _as_group(child, ns)
            target.append(sub)
            keep = preserve if child.get(_XML_SPACE) is None else child.get(_XML_SPACE) == "preserve"
            _layout(child, sub, _Props(props, child), ns, fonts, pieces, state, notes, keep)
        _emit(child.tail, target, props, fonts, pieces, state, preserve, notes)


def _emit(s, target, props: _Props, fonts: _Fonts, pieces, state, preserve, notes) -> None:
    if not s:
        return
    s = _collapse(s, preserve)
    if not preserve and (state["first"] or state.get("space")):  # spaces collapse across runs
        s = s.lstrip(" ")
    if not s:
        return
    state["first"] = False
    state["space"] = s.endswith(" ")
    try:
        verts, codes, advance = fonts.run(s, props)
    except Exception:  # noqa: BLE001  (a glyph FreeType cannot load: the run is left out, said once)
        notes.add("text the font machinery could not draw (left out)")
        return
    chunk = pieces[-1]
    if chunk["start"] is None:  # the chunk's first glyphs: their element's text-anchor is the chunk's
        chunk["start"] = state["x"]
        chunk["anchor"] = props.anchor
    y = state["y"]
    if props.shifts or props.dominant not in ("auto", "alphabetic") or props.alignment != "auto" \
            or props.decorations:
        m = fonts.metrics(props)
        y += baseline_offset(m, props.size, props.dominant, props.alignment, props.shifts)
    if len(verts):
        verts[:, 0] += state["x"]
        verts[:, 1] += y
        chunk["items"].append((target, verts, codes))
    if props.decorations and advance > 0:  # drawn in the paint of the element declaring them
        m = fonts.metrics(props)
        new = []
        for kind, owner in props.decorations:
            bars, bar_codes = decoration_bars(m, props.size, (kind,), 0.0, advance, 0.0)
            if len(bars):
                bars[:, 0] += state["x"]
                bars[:, 1] += y
                new.append((owner.target if owner.target is not None else target, bars, bar_codes))
        if s.strip(" ") or preserve:  # spaces are decorated only where text follows them
            chunk["items"].extend(chunk.pop("pending", []) + new)
        else:
            chunk.setdefault("pending", []).extend(new)
    end = state["x"] + advance
    if preserve:
        chunk["trimmed"] = end
    elif s.strip(" "):  # the end without trailing spaces, for the text's last chunk
        chunk["trimmed"] = end
        if state["space"] and chunk["anchor"] != "start":
            try:
                chunk["trimmed"] = state["x"] + fonts.run(s.rstrip(" "), props)[2]
            except Exception:  # noqa: BLE001
                pass
    state["x"] += advance
    chunk["end"] = end
