"""Raster preview of a packing (matplotlib Agg, no pyplot state)."""

from __future__ import annotations

import io
import math
import sys
from pathlib import Path

import numpy as np
import shapely

from ..errors import OutputError, ParameterError
from ..types import ArtPath, Container, PlacedArt
from ..io.files import atomic_write_bytes
from ..io.regions import RegionTooComplex, rings_to_region
from .container_paint import check_paint, outline_colour, outline_width
from .frame import packing_frame

__all__ = ["contact_sheet_png", "png_bytes", "render_png"]

_DPI = 100
_CAPS = {"butt": "butt", "round": "round", "square": "projecting"}
_JOINS = {"miter": "miter", "round": "round", "bevel": "bevel"}


def _fill_path(art: ArtPath):
    """matplotlib Path filling ``art`` like an SVG renderer (nonzero fill in matplotlib)."""
    from matplotlib.path import Path as MPath

    rings = [np.asarray(p, dtype=float) for p in art.subpaths if len(p) >= 3]
    if not rings:
        return None
    if art.style.fill_rule == "evenodd":
        try:
            region = rings_to_region(rings, "evenodd")
        except RegionTooComplex:  # pathological outline: draw it with the nonzero rule
            region = None
    else:
        region = None
    if region is not None:
        polys = [
            g
            for g in shapely.get_parts(region)
            if isinstance(g, shapely.Polygon) and not g.is_empty
        ]
        rings = []
        for poly in polys:
            poly = shapely.geometry.polygon.orient(poly, 1.0)  # exterior CCW, holes CW
            rings.append(np.asarray(poly.exterior.coords)[:-1])
            rings.extend(np.asarray(r.coords)[:-1] for r in poly.interiors)
        if not rings:
            return None
    verts, codes = [], []
    for r in rings:
        verts.append(r)
        verts.append(r[:1])
        codes.append(
            np.concatenate(
                [[MPath.MOVETO], np.full(len(r) - 1, MPath.LINETO), [MPath.CLOSEPOLY]]
            )
        )
    return MPath(np.concatenate(verts), np.concatenate(codes).astype(MPath.code_type))


def _stroke_path(art: ArtPath):
    from matplotlib.path import Path as MPath

    verts, codes = [], []
    for pts, closed in zip(art.subpaths, art.closed):
        pts = np.asarray(pts, dtype=float)
        if len(pts) < 2:
            continue
        verts.append(pts)
        c = [MPath.MOVETO] + [MPath.LINETO] * (len(pts) - 1)
        if closed:
            verts.append(pts[:1])
            c.append(MPath.CLOSEPOLY)
        codes.append(np.asarray(c))
    if not verts:
        return None
    return MPath(np.concatenate(verts), np.concatenate(codes).astype(MPath.code_type))


def _art_patches(art: ArtPath, stroke_scale: float, pt_per_unit: float) -> list:
    """The matplotlib patches that paint ``art`` (its fill and its stroke, in its paint
    order), not yet added to any axes."""
    from matplotlib.colors import to_rgba
    from matplotlib.patches import PathPatch

    st = art.style
    out = []

    def fill():
        if st.fill is not None and st.opacity * st.fill_opacity > 0:
            fp = _fill_path(art)
            if fp is not None:
                out.append(PathPatch(fp, facecolor=to_rgba(st.fill, st.opacity * st.fill_opacity),
                                     edgecolor="none", linewidth=0))

    def stroke():
        width = st.stroke_width * stroke_scale * pt_per_unit
        if st.stroke is not None and st.opacity * st.stroke_opacity > 0 and width > 0:
            sp = _stroke_path(art)
            if sp is not None:
                out.append(PathPatch(
                    sp,
                    facecolor="none",
                    edgecolor=to_rgba(st.stroke, st.opacity * st.stroke_opacity),
                    linewidth=width,
                    capstyle=_CAPS.get(st.stroke_linecap, "butt"),
                    joinstyle=_JOINS.get(st.stroke_linejoin, "miter"),
                    linestyle=_dashes(st, stroke_scale * pt_per_unit, width),
                ))

    order = st.paint_order.split() if st.paint_order != "normal" else ["fill", "stroke"]
    for part in order:  # paint-order: "stroke fill markers" draws the stroke first
        {"fill": fill, "stroke": stroke}.get(part, lambda: None)()
    return out


def _add_patches(ax, patches: list) -> None:
    """Draw ``patches`` on ``ax`` in their order, as each would be drawn added to it alone
    (``ax.add_artist``: the axes' data transform, clipped to the axes), through one artist
    of the axes: adding thousands of artists to an axes costs more than drawing them."""
    if not patches:
        return
    from matplotlib.artist import Artist
    from matplotlib.transforms import Bbox, TransformedBbox

    class _InOrder(Artist):
        zorder = patches[0].get_zorder()  # where the patches would have been sorted

        def draw(self, renderer):
            for p in patches:
                p.draw(renderer)

    clip = TransformedBbox(Bbox.unit(), ax.patch.get_transform())  # what add_artist clips to
    for p in patches:
        p.set_transform(ax.transData)
        p.set_clip_box(clip)
    ax.add_artist(_InOrder())


def _dashes(st, pt_per_unit: float, width: float):
    """matplotlib's line style for the stroke's dashes: lengths in points, divided by
    the line width, which matplotlib multiplies them by."""
    if not st.stroke_dasharray or width <= 0:
        return "solid"
    k = pt_per_unit / width
    return (st.stroke_dashoffset * k, [d * k for d in st.stroke_dasharray])


def render_png(
    path: str | Path,
    container: Container,
    placed: list[PlacedArt],
    size_px: int = 1200,
    background: str | None = "white",
    show_container: bool = True,
    container_paint: str = "outline",
    gap: float | None = None,
) -> None:
    """Render the packing to a PNG whose longer side is ``size_px`` pixels.

    The frame is the SVG's (:func:`~repulsionpak.render.frame.packing_frame`: the
    container file's viewBox, grown where the drawing reaches past it; without one, the
    drawing plus a 2 % margin), y down, equal aspect, no axes. The container is drawn as
    ``container_paint`` says (``"outline"``: its region as a thin stroke of
    :func:`~repulsionpak.render.container_paint.outline_width` for ``gap``; ``"as-drawn"``:
    its own shapes; ``"none"``), nothing with ``show_container`` False. Fill rules are
    honoured (evenodd fills are rebuilt as oriented polygons, since matplotlib fills by
    winding); stroke widths are in data units. ``background`` None or ``"none"`` gives a
    transparent image. Deterministic; written atomically.
    """
    atomic_write_bytes(path, png_bytes(container, placed, size_px, background, show_container, path=path,
                                       container_paint=container_paint, gap=gap))


def png_bytes(
    container: Container,
    placed: list[PlacedArt],
    size_px: int = 1200,
    background: str | None = "white",
    show_container: bool = True,
    path: str | Path = "<png>",
    container_paint: str = "outline",
    gap: float | None = None,
) -> bytes:
    """The PNG file :func:`render_png` writes, as bytes (``path`` only names it in errors)."""
    check_paint(container_paint)
    if not show_container:
        container_paint = "none"
    try:
        size_px = int(size_px)
    except (TypeError, ValueError):
        raise ParameterError(f"size_px must be an integer, got {size_px!r}") from None
    if not 16 <= size_px <= 20000:
        raise ParameterError(f"size_px must be between 16 and 20000, got {size_px}")
    import matplotlib

    if (
        "matplotlib.pyplot" not in sys.modules
    ):  # never switch the backend under a running pyplot
        matplotlib.use("Agg")
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    if not all(math.isfinite(v) for v in container.bounds):
        raise OutputError(
            f"{path}: the container has non-finite bounds; nothing was rendered"
        )
    stroke_w = outline_width(container, gap)
    x0, y0, w, h = packing_frame(container, placed, container_paint, stroke_w).view
    w, h = max(w, 1e-12), max(h, 1e-12)
    if w >= h:
        W, H = size_px, max(1, round(size_px * h / w))
    else:
        W, H = max(1, round(size_px * w / h)), size_px
    # grow the shorter data extent so that data and pixel aspect ratios agree exactly
    upp = max(w / W, h / H)  # data units per pixel
    cx, cy = x0 + w / 2, y0 + h / 2
    w, h = W * upp, H * upp
    x0, y0 = cx - w / 2, cy - h / 2
    pt_per_unit = (1.0 / upp) * 72.0 / _DPI

    fig = Figure(figsize=(W / _DPI, H / _DPI), dpi=_DPI)
    canvas = FigureCanvasAgg(fig)
    transparent = background is None or str(background).lower() == "none"
    if not transparent:
        from matplotlib.colors import is_color_like

        if not is_color_like(background):
            raise ParameterError(
                f"background {background!r} is not a colour; use e.g. 'white', '#ffffff' or None"
            )
    fig.patch.set_facecolor("none" if transparent else background)
    fig.patch.set_alpha(0.0 if transparent else 1.0)
    ax = fig.add_axes((0, 0, 1, 1))
    ax.set_axis_off()
    ax.patch.set_visible(False)
    ax.set_xlim(x0, x0 + w)
    ax.set_ylim(y0 + h, y0)  # y down
    ax.set_aspect(
        "equal"
    )  # data and pixel aspect agree, so the axes keep the whole figure

    if container_paint == "as-drawn" and container.paths:
        _add_patches(ax, [q for art in container.paths for q in _art_patches(art, 1.0, pt_per_unit)])
    elif container_paint != "none":  # the outline (also as-drawn's, for a container without shapes)
        from matplotlib.patches import PathPatch
        from matplotlib.path import Path as MPath

        if container_paint == "outline":
            # at least a pixel wide: a thumbnail still shows it
            colour, width = outline_colour(container), max(stroke_w * pt_per_unit, 72.0 / _DPI)
        else:  # as the SVG writer's outline of a container without shapes
            x0c, y0c, x1c, y1c = container.bounds
            colour, width = "#000000", math.hypot(x1c - x0c, y1c - y0c) / 1000 * pt_per_unit
        for poly in shapely.get_parts(container.region):
            if isinstance(poly, shapely.Polygon) and not poly.is_empty:
                for ring in [poly.exterior, *poly.interiors]:
                    pts = np.asarray(ring.coords)
                    codes = np.full(len(pts), MPath.LINETO, dtype=MPath.code_type)
                    codes[0], codes[-1] = MPath.MOVETO, MPath.CLOSEPOLY
                    ax.add_artist(  # not add_patch: the limits are set, no data-limit update
                        PathPatch(
                            MPath(pts, codes),
                            facecolor="none",
                            edgecolor=colour,
                            linewidth=width,
                            joinstyle="round",
                        )
                    )
    _add_patches(ax, [q for pa in placed for art in pa.paths
                      for q in _art_patches(art, pa.stroke_scale, pt_per_unit)])

    buf = io.BytesIO()
    canvas.print_png(buf, metadata={"Software": "repulsionpak"})
    return buf.getvalue()


def contact_sheet_png(
    tiles: list[bytes | None],
    labels: list[str],
    tile_px: int,
    columns: int | None = None,
    label_px: int = 18,
) -> bytes:
    """A grid of thumbnails as one PNG, each tile with a one-line label under it.

    ``tiles[i]`` is a PNG (as :func:`png_bytes` makes, longer side at most ``tile_px``)
    or None for an empty tile (a failed job: only its label shows). Tiles run left to
    right, top to bottom, ``columns`` per row (default: ceil(sqrt(n))). The sheet is
    exactly ``columns * tile_px`` wide and ``rows * (tile_px + label_px)`` high, so the
    tile count can be read back from its size. Deterministic.
    """
    if len(tiles) != len(labels):
        raise ValueError("need one label per tile")
    n = len(tiles)
    if n == 0:
        raise ValueError("no tiles")
    if not 16 <= tile_px <= 4000:
        raise ParameterError(f"tile_px must be between 16 and 4000, got {tile_px}")
    cols = columns or math.ceil(math.sqrt(n))
    rows = math.ceil(n / cols)
    cell_h = tile_px + label_px
    W, H = cols * tile_px, rows * cell_h
    import matplotlib

    if "matplotlib.pyplot" not in sys.modules:
        matplotlib.use("Agg")
    import matplotlib.image as mimage
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(W / _DPI, H / _DPI), dpi=_DPI)
    canvas = FigureCanvasAgg(fig)
    fig.patch.set_facecolor("white")
    font_pt = max(4.0, 0.62 * label_px * 72.0 / _DPI)
    for i, (tile, label) in enumerate(zip(tiles, labels)):
        r, c = divmod(i, cols)
        x0, y_top = c * tile_px, r * cell_h  # pixels, y down
        if tile is not None:
            img = mimage.imread(io.BytesIO(tile), format="png")
            th, tw = img.shape[:2]
            if th > tile_px or tw > tile_px:
                raise ValueError(f"tile {i} is {tw}x{th} px, larger than {tile_px}")
            # figimage places the image's lower-left corner, in pixels from the bottom
            xo = x0 + (tile_px - tw) // 2
            yo = H - (y_top + (tile_px - th) // 2 + th)
            fig.figimage(img, xo=xo, yo=yo, origin="upper")
        else:  # an empty tile shows as a light square
            from matplotlib.patches import Rectangle

            pad = max(2, tile_px // 40)
            fig.add_artist(Rectangle(((x0 + pad) / W, 1.0 - (y_top + tile_px - pad) / H),
                                     (tile_px - 2 * pad) / W, (tile_px - 2 * pad) / H,
                                     transform=fig.transFigure, facecolor="#f0f0f0", edgecolor="none"))
        fig.text((x0 + tile_px / 2) / W, 1.0 - (y_top + tile_px + label_px / 2) / H, label,
                 ha="center", va="center", fontsize=font_pt, color="#222222" if tile is not None else "#b00020")
    buf = io.BytesIO()
    canvas.print_png(buf, metadata={"Software": "repulsionpak"})
    return buf.getvalue()
