"""Extensions → Arrange → Pack into shape…: the selection packed into its closed shape.

The topmost selected closed shape is the container (as Inkscape's Object → Clip → Set
takes the topmost object as the clip); the other selected objects (groups, paths, text,
clones) are the elements; the objects of a layer named in the dialog are the secondary
(pocket) elements. The result is a new top-level layer labelled ``Packing`` holding the
packed copies, their styles resolved, in the document's user units; the originals stay
as they are. The layer records the selection and the settings, so that running the effect
with that layer (or anything in it) selected packs it again in place: the same packing,
or a new one with *New seed*.
"""

from __future__ import annotations

import os
import secrets
import sys

import inkex
from inkex.utils import AbortExtension
from lxml import etree

from . import library
from .standalone import INKSCAPE_NS, composed_transform, is_closed_shape, local_name, standalone_svg

LAYER_LABEL = "Packing"
#: the layer attribute that marks a Packing layer and holds the format of its settings
MARK = "data-repulsionpak"
PAINTS = ("none", "outline", "as-drawn")
_XLINK_HREF = "{http://www.w3.org/1999/xlink}href"


def _bool(text) -> bool:
    """inkex's own boolean argument type (Inkscape passes ``true``/``false``)."""
    return inkex.Boolean(text) if hasattr(inkex, "Boolean") else str(text).lower() in ("true", "1", "yes")


class PackIntoShape(inkex.EffectExtension):
    """The effect: read the selection, pack it with repulsionpak, add the Packing layer."""

    def add_arguments(self, pars):
        pars.add_argument("--tab", default="settings")
        pars.add_argument("--gap", type=float, default=0.0,
                          help="gap between neighbouring elements, document units (0: automatic)")
        pars.add_argument("--count", type=int, default=0, help="number of elements (0: automatic)")
        pars.add_argument("--seed", type=int, default=1, help="random seed")
        pars.add_argument("--reseed", type=_bool, default=False,
                          help="draw a new seed (re-packing a Packing layer)")
        pars.add_argument("--rotation", default="free", help="free, fixed or limited")
        pars.add_argument("--max_rotation", type=float, default=20.0,
                          help="limited rotation: degrees either side of the art as drawn")
        pars.add_argument("--rigid", type=_bool, default=False, help="the art never deforms")
        pars.add_argument("--stiffness", type=float, default=1.0, help="spring stiffness multiplier")
        pars.add_argument("--pocket_fill", type=_bool, default=True,
                          help="fill the pockets with small copies (or the secondary layer's objects)")
        pars.add_argument("--draft", type=_bool, default=False,
                          help="a quicker, slightly looser packing (repulsionpak pack --draft)")
        pars.add_argument("--secondary_layer", default="", help="label of a layer of pocket elements")
        pars.add_argument("--container_paint", default="none", help="none, outline or as-drawn")

    # -- the effect ---------------------------------------------------------------------
    def effect(self):
        try:
            self._effect()
        except AbortExtension:
            raise
        except library.PackError as exc:
            raise AbortExtension(f"repulsionpak: {exc}") from None
        except Exception as exc:  # a bug: one line in Inkscape's message box, the traceback on request
            if os.environ.get("REPULSIONPAK_DEBUG"):
                raise
            first = " ".join(str(exc).split()) or type(exc).__name__
            raise AbortExtension(f"repulsionpak: internal error ({type(exc).__name__}: {first}); "
                                 "set REPULSIONPAK_DEBUG=1 for the traceback") from None

    def _effect(self):
        svg = self.svg
        selected = list(svg.selection.rendering_order()) if len(svg.selection) else []
        if not selected:
            raise AbortExtension("repulsionpak: nothing selected: select a closed shape (the container) "
                                 "and the objects to pack into it")
        layer = _packing_layer_of(selected)
        if layer is not None:  # pack that layer again from what it records
            settings = _read_settings(layer)
            if self.options.reseed:
                settings["seed"] = str(secrets.randbelow(2**31))
            container, elements = self._recorded_selection(settings)
            for child in list(layer):
                layer.remove(child)
        else:
            settings = self._settings_from_options()
            container, elements = _roles(selected)
            layer = None
        secondary = self._secondary(settings.get("secondary-layer", ""), exclude=[container, *elements])
        if not elements:
            raise AbortExtension("repulsionpak: only the container is selected: select the objects to "
                                 "pack into it as well (Shift+click)")
        req = self._request(settings)
        vb = svg.get_viewbox()
        data, info = library.pack_documents(
            (container.get_id(), standalone_svg(svg, container, vb)),
            [(e.get_id(), standalone_svg(svg, e, vb)) for e in elements],
            [(s.get_id(), standalone_svg(svg, s, vb)) for s in secondary], req)
        settings["seed"] = str(info["seed"])
        settings["container"] = container.get_id()
        settings["elements"] = " ".join(e.get_id() for e in elements)
        if layer is None:
            layer = svg.add(inkex.Layer.new(LAYER_LABEL))
        _fill_layer(svg, layer, data, settings, info, self._uu_per_unit())

    # -- the selection ------------------------------------------------------------------
    def _recorded_selection(self, settings: dict):
        """The container and elements a Packing layer was made from (still in the document)."""
        ids = [settings.get("container", ""), *settings.get("elements", "").split()]
        nodes = [self.svg.getElementById(i) if i else None for i in ids]
        missing = [i for i, n in zip(ids, nodes) if n is None]
        if missing:
            raise AbortExtension(f"repulsionpak: the objects this Packing layer was made from are gone "
                                 f"({', '.join(missing)}): select the container and elements again")
        return nodes[0], nodes[1:]

    def _secondary(self, label: str, exclude) -> list:
        """The drawable objects of the layer(s) labelled ``label`` (none when empty)."""
        label = (label or "").strip()
        if not label:
            return []
        layers = [g for g in self.svg.iter() if local_name(g) == "g"
                  and g.get(f"{{{INKSCAPE_NS}}}groupmode") == "layer"
                  and (g.get(f"{{{INKSCAPE_NS}}}label") or "").strip() == label]
        if not layers:
            raise AbortExtension(f"repulsionpak: no layer is labelled {label!r} (the secondary elements' layer)")
        ex = {id(n) for n in exclude}
        out = [c for lay in layers for c in lay if isinstance(c, inkex.ShapeElement)
               and local_name(c) not in ("defs", "title", "desc", "metadata") and id(c) not in ex
               and not (local_name(c) == "g" and c.get(f"{{{INKSCAPE_NS}}}groupmode") == "layer")]
        if not out:
            raise AbortExtension(f"repulsionpak: the layer {label!r} holds no objects to use as secondary elements")
        return out

    # -- settings ---------------------------------------------------------------------
    def _settings_from_options(self) -> dict:
        o = self.options
        seed = secrets.randbelow(2**31) if o.reseed else o.seed
        return {"gap": f"{o.gap:.10g}" if o.gap and o.gap > 0 else "auto",
                "unit": self.svg.document_unit if hasattr(self.svg, "document_unit") else "px",
                "count": str(o.count) if o.count and o.count > 0 else "auto",
                "seed": str(seed), "rotation": str(o.rotation), "max-rotation": f"{o.max_rotation:.10g}",
                "rigid": "true" if o.rigid else "false", "stiffness": f"{o.stiffness:.10g}",
                "pocket-fill": "true" if o.pocket_fill else "false", "draft": "true" if o.draft else "false",
                "secondary-layer": (o.secondary_layer or "").strip(), "container-paint": str(o.container_paint)}

    def _request(self, s: dict) -> library.Request:
        """The library request of the settings ``s`` (the gap converted to user units)."""
        rotation = s.get("rotation", "free")
        if rotation not in library.rotations():
            raise AbortExtension(f"repulsionpak: rotation must be one of {', '.join(library.rotations())}, "
                                 f"got {rotation!r}")
        paint = s.get("container-paint", "none")
        if paint not in PAINTS:
            raise AbortExtension(f"repulsionpak: container paint must be one of {', '.join(PAINTS)}, got {paint!r}")
        try:
            gap = None if s.get("gap", "auto") == "auto" else float(s["gap"])
            count = None if s.get("count", "auto") == "auto" else int(s["count"])
            seed = int(s.get("seed", "1"))
            stiffness = float(s.get("stiffness", "1"))
            max_rotation = float(s.get("max-rotation", "20"))
        except ValueError as exc:
            raise AbortExtension(f"repulsionpak: a setting of this Packing layer is not a number ({exc})") from None
        if gap is not None:
            if not gap > 0:
                raise AbortExtension(f"repulsionpak: the gap must be positive, got {gap:g}")
            gap = gap * self._uu_per_unit(s.get("unit"))
        if seed < 0:
            raise AbortExtension(f"repulsionpak: the seed must be >= 0, got {seed}")
        if not stiffness > 0:
            raise AbortExtension(f"repulsionpak: the stiffness must be > 0, got {stiffness:g}")
        return library.Request(seed=seed, gap=gap, count=count, rotation=rotation, max_rotation=max_rotation,
                               rigid=s.get("rigid") == "true", stiffness=stiffness,
                               pocket_fill=s.get("pocket-fill", "true") == "true", container_paint=paint,
                               draft=s.get("draft", "false") == "true")

    def _uu_per_unit(self, unit: str | None = None) -> float:
        """User units of the root per document unit (``unit``; default the document's)."""
        svg = self.svg
        unit = unit or (svg.document_unit if hasattr(svg, "document_unit") else "px")
        try:
            return float(svg.viewport_to_unit(f"1{unit}", "px"))
        except Exception:  # inkex without viewport_to_unit: the viewBox and the width
            vb = svg.get_viewbox()
            width = svg.get("width")
            if not vb or not vb[2] or not width:
                return float(inkex.units.convert_unit(f"1{unit}", "px"))
            return vb[2] / float(inkex.units.convert_unit(width, unit))


# -- the roles of the selected objects ---------------------------------------------------
def _roles(selected: list):
    """(container, elements) of the selection in rendering order (bottom to top)."""
    closed = [n for n in selected if is_closed_shape(n)]
    if not closed:
        raise AbortExtension("repulsionpak: no closed shape is selected: the container must be a closed "
                             "path, rectangle, circle, ellipse or polygon (Path → Object to Path closes "
                             "nothing; close the path with Z)")
    container = closed[-1]  # the topmost
    return container, [n for n in selected if n is not container]


def _packing_layer_of(selected: list):
    """The Packing layer the selection is (or is in), if any."""
    for node in selected:
        cur = node
        while cur is not None and isinstance(cur, inkex.BaseElement):
            if cur.get(MARK) is not None:
                return cur
            cur = cur.getparent()
    return None


def _read_settings(layer) -> dict:
    prefix = "data-rp-"
    return {k[len(prefix):]: v for k, v in layer.attrib.items() if isinstance(k, str) and k.startswith(prefix)}


# -- the new layer ---------------------------------------------------------------------------
def _fill_layer(svg, layer, data: bytes, settings: dict, info: dict, uu_per_unit: float) -> None:
    """Put the packing's element groups (and its container group unless the paint is
    ``none``) into ``layer``, with unique ids, and record the settings on the layer."""
    packed = etree.fromstring(data)
    tr = composed_transform(layer.getparent())
    if tr == inkex.Transform():
        layer.attrib.pop("transform", None)
    else:  # the packing is in root user units; the layer draws in its parent's
        layer.set("transform", str(-tr))
    layer.set(MARK, "1")
    for k, v in settings.items():
        layer.set(f"data-rp-{k}", v)
    layer.set("data-rp-gap-used", f"{info['gap'] / uu_per_unit:.6g}")
    layer.set("data-rp-primary", str(info["n_primary"]))
    layer.set("data-rp-secondary", str(info["n_secondary"]))
    groups = []
    if settings.get("container-paint", "none") != "none":
        groups += [g for g in packed if local_name(g) == "g" and g.get("id") == "container"]
    groups += [g for g in packed if local_name(g) == "g" and g.get("id") == "elements"]
    taken = set(svg.ids) if hasattr(svg, "ids") else {e.get("id") for e in svg.iter() if isinstance(e.tag, str)}
    prefix = _free_prefix(taken, layer.get_id())
    for g in groups:
        _rename_ids(g, prefix)
        for k, el in enumerate(e for e in g.iter() if "element" in (e.get("class") or "").split()):
            if not el.get("id"):  # selectable by id (re-running the effect on a copy)
                el.set("id", f"{prefix}copy{k + 1}")
        g.set("id", f"{prefix}{g.get('id')}")
        g.set(f"{{{INKSCAPE_NS}}}label", "container" if g.get("id").endswith("container") else "elements")
        layer.append(_inkex(g))


def _inkex(el):
    """``el`` (plain lxml) as inkex elements, so the document's id bookkeeping sees them."""
    return inkex.load_svg(etree.tostring(el)).getroot()


def _free_prefix(taken: set, base: str) -> str:
    prefix = f"{base}-"
    k = 1
    while any(t and t.startswith(prefix) for t in taken):
        k += 1
        prefix = f"{base}-{k}-"
    return prefix


def _rename_ids(root, prefix: str) -> None:
    """Prefix every id under ``root`` and every reference to them (``url(#id)``, ``href``)."""
    ids = {el.get("id") for el in root.iter() if isinstance(el.tag, str) and el.get("id")}
    if not ids:
        return
    for el in root.iter():
        if not isinstance(el.tag, str):
            continue
        if el.get("id") in ids:
            el.set("id", prefix + el.get("id"))
        for key, value in list(el.attrib.items()):
            if key in (_XLINK_HREF, "href") and value[1:] in ids and value.startswith("#"):
                el.set(key, f"#{prefix}{value[1:]}")
            elif "url(" in value:
                for i in ids:
                    value = value.replace(f"url(#{i})", f"url(#{prefix}{i})")
                el.set(key, value)


def main(argv=None) -> None:
    """``python -m repulsionpak.inkscape [--id=ID ...] [options] INPUT.svg > OUTPUT.svg``."""
    PackIntoShape().run(sys.argv[1:] if argv is None else argv)


__all__ = ["PackIntoShape", "LAYER_LABEL", "main"]
