"""The simulation as an animation: ``repulsionpak pack ... --movie OUT.gif|OUT.mp4``.

A :class:`MovieRecorder` is an ``on_snapshot`` consumer (see
:class:`~repulsionpak.sim.runner.Snapshot`): during the run it only keeps a float32 copy
of the mesh vertices every few iterations (cheap); :meth:`MovieRecorder.write` draws the
frames after the run and encodes them (GIF through Pillow, MP4 through imageio-ffmpeg,
which ships its own ffmpeg binary), then holds the finished packing for ``hold``
seconds at the end.

Frames show the art itself, deformed by the same map the final render uses
(:func:`~repulsionpak.render.deform.map_plan`: the art's dense samples as a linear
function of the mesh vertices), drawn as filled polygons with Pillow (supersampled
twice, so edges are smooth); the last frame draws the finished packing's placed art.

Frame stride: ``every=N`` keeps the state every N iterations of each phase (plus the
last state of each phase). Without it the stride adapts to the run, whose length is not
known in advance (it stops on convergence): it starts at the snapshot cadence and
doubles, dropping every other frame, whenever more than ``2 * frames`` are held, so a
run of any length ends with ``frames`` to ``2 * frames`` frames (each phase's first and
last snapshot always among them); the frame rate then makes the film about ``seconds``
long.
"""

from __future__ import annotations

import math
import os
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import OutputError, ParameterError
from ..geometry.outline import signed_area

__all__ = ["FORMATS", "MovieRecorder", "FrameRenderer", "MovieInfo", "movie_format", "check_movie_output"]

#: movie formats by file extension
FORMATS = {".gif": "gif", ".mp4": "mp4"}
MP4_HINT = "pip install 'repulsionpak[mp4]'"
#: snapshot cadence of the simulation when no stride is asked for (pack()'s default)
BASE_EVERY = 25
#: GIF frame delays are whole centiseconds; browsers slow delays under 2 cs down to 10 cs
MIN_DELAY_CS, MAX_DELAY_CS = 4, 10
SUPERSAMPLE = 2


def movie_format(path: str | Path) -> str:
    """``"gif"`` or ``"mp4"`` from the extension of ``path``; ParameterError otherwise."""
    ext = Path(path).suffix.lower()
    if ext not in FORMATS:
        raise ParameterError(f"{path}: unknown movie format {ext or '(no extension)'!r}; "
                             "the movie must end in .gif or .mp4")
    return FORMATS[ext]


def check_movie_output(path: str | Path) -> str:
    """Validate a movie path before a run: known extension, and for MP4 an installed
    imageio-ffmpeg (OutputError naming the install command). Returns the format."""
    fmt = movie_format(path)
    if fmt == "mp4":
        try:
            import imageio_ffmpeg  # noqa: F401, PLC0415
        except ImportError:
            raise OutputError(f"{path}: writing MP4 needs the imageio-ffmpeg package: "
                              f"{MP4_HINT} (or write a .gif)") from None
    return fmt


# -- drawing -------------------------------------------------------------------------------

def _rgb(colour: str | None, cache: dict) -> tuple[int, int, int] | None:
    if colour is None:
        return None
    if colour not in cache:
        from PIL import ImageColor  # noqa: PLC0415

        try:
            cache[colour] = ImageColor.getrgb(colour)[:3]
        except ValueError:  # a paint server reference or an unusual colour: a neutral grey
            cache[colour] = (150, 150, 150)
    return cache[colour]


@dataclass
class _TemplateDraw:
    """Per template: the rows of its map that the frames use, and how they form paths."""

    M: np.ndarray  # (P', N_t) samples as a linear function of the mesh vertices
    cols: np.ndarray | None = None  # the vertices M applies to (the spline's centres); None: all
    # per art path: (style, [(start, stop, closed), ...]) into the P' rows
    paths: list = field(default_factory=list)


class FrameRenderer:
    """Draws frames of ``container`` (fixed view: its bounds plus 2 %) at ``size_px``
    pixels along the longer side; both sides are even (H.264 needs that)."""

    def __init__(self, container, size_px: int = 600, background: str = "white"):
        if not 64 <= int(size_px) <= 4000:
            raise ParameterError(f"movie frame size must be between 64 and 4000 px, got {size_px}")
        self.container = container
        x0, y0, x1, y1 = container.bounds
        w, h = max(x1 - x0, 1e-12), max(y1 - y0, 1e-12)
        m = 0.02 * max(w, h)
        x0, y0, w, h = x0 - m, y0 - m, w + 2 * m, h + 2 * m
        s = int(size_px)
        W, H = (s, max(2, round(s * h / w))) if w >= h else (max(2, round(s * w / h)), s)
        W, H = W + W % 2, H + H % 2
        upp = max(w / W, h / H)  # container units per pixel
        cx, cy = x0 + w / 2, y0 + h / 2
        self.size = (W, H)
        self.origin = np.array([cx - W * upp / 2, cy - H * upp / 2])
        self.px_per_unit = SUPERSAMPLE / upp  # on the supersampled canvas
        self.background = background
        self._colours: dict = {}
        self._templates: dict[int, _TemplateDraw] = {}
        self._models: dict = {}
        self._base = None

    # pixel coordinates on the supersampled canvas
    def _px(self, p: np.ndarray) -> np.ndarray:
        return (p - self.origin) * self.px_per_unit

    def _canvas(self):
        from PIL import Image  # noqa: PLC0415

        if self._base is None:
            W, H = self.size
            img = Image.new("RGB", (W * SUPERSAMPLE, H * SUPERSAMPLE), self.background)
            self._draw_container(img)
            self._base = img
        return self._base.copy()

    def _draw_container(self, img) -> None:
        from PIL import ImageDraw  # noqa: PLC0415

        c = self.container
        if c.paths:
            d = ImageDraw.Draw(img)
            for art in c.paths:
                self._draw_path(img, d, [self._px(np.asarray(p, float)) for p in art.subpaths],
                                list(art.closed), art.style, 1.0)
        else:
            import shapely  # noqa: PLC0415

            d = ImageDraw.Draw(img)
            for poly in shapely.get_parts(c.region):
                for ring in [poly.exterior, *poly.interiors]:
                    q = self._px(np.asarray(ring.coords))
                    d.line(q.ravel().tolist(), fill=(0, 0, 0), width=SUPERSAMPLE)

    def _draw_path(self, img, draw, rings: list[np.ndarray], closed: list[bool], style,
                   stroke_scale: float) -> None:
        """One art path, ``rings`` in canvas pixels: fill (its fill rule approximated:
        holes are rings turning the other way, or every other ring for evenodd) and stroke."""
        from PIL import Image, ImageChops, ImageDraw  # noqa: PLC0415

        if style.opacity <= 0:
            return
        fill = _rgb(style.fill, self._colours)
        alpha = style.opacity * style.fill_opacity
        closed_rings = [r for r, c in zip(rings, closed) if len(r) >= 3]
        if fill is not None and alpha > 0 and closed_rings:
            if len(closed_rings) == 1 and alpha >= 0.999:
                draw.polygon(closed_rings[0].ravel().tolist(), fill=fill)
            else:
                allp = np.concatenate(closed_rings)
                lo = np.maximum(np.floor(allp.min(axis=0)).astype(int) - 1, 0)
                hi = np.minimum(np.ceil(allp.max(axis=0)).astype(int) + 2, img.size)
                if (hi > lo).all():
                    size = tuple(int(v) for v in hi - lo)
                    mask = Image.new("1", size, 0)
                    if style.fill_rule == "evenodd":
                        for r in closed_rings:
                            one = Image.new("1", size, 0)
                            ImageDraw.Draw(one).polygon((r - lo).ravel().tolist(), fill=1)
                            mask = ImageChops.logical_xor(mask, one)
                    else:  # nonzero: rings turning like the largest one add, the others cut
                        areas = [signed_area(r) for r in closed_rings]
                        sign = np.sign(areas[int(np.argmax(np.abs(areas)))]) or 1.0
                        d = ImageDraw.Draw(mask)
                        for r, a in sorted(zip(closed_rings, areas), key=lambda ra: np.sign(ra[1]) != sign):
                            d.polygon((r - lo).ravel().tolist(), fill=1 if np.sign(a) == sign else 0)
                    m = Image.new("L", size, 0)
                    m.paste(round(255 * min(alpha, 1.0)), (0, 0, *size), mask)
                    img.paste(fill, (int(lo[0]), int(lo[1]), int(hi[0]), int(hi[1])), m)
        stroke = _rgb(style.stroke, self._colours)
        width = style.stroke_width * stroke_scale * self.px_per_unit
        if stroke is not None and style.stroke_opacity * style.opacity > 0 and width > 0:
            w = max(1, round(width))
            for r, c in zip(rings, closed):
                if len(r) < 2:
                    continue
                if c:
                    r = np.vstack([r, r[:1]])
                draw.line(r.ravel().tolist(), fill=stroke, width=w, joint="curve")

    def _template(self, index: int, template, render_params) -> _TemplateDraw:
        td = self._templates.get(index)
        if td is not None:
            return td
        from .deform import map_plan  # noqa: PLC0415

        rp = render_params
        plan = map_plan(template, rp.smooth_map, rp.samples, rp.smoothing)
        rows, paths = [], []
        n = 0
        for art, starts, subs in zip(template.element.paths, plan.seg_start, plan.curves):
            sp = []
            for st, sub in zip(starts, subs):
                a, b = int(st[0]), int(st[-1])
                if b - a < 2:
                    continue
                pts = plan.points[a:b]
                length = float(np.hypot(*np.diff(pts, axis=0).T).sum())
                # a point per 3 canvas pixels (1.5 px of the frame) of the element at
                # its nominal final size, at least 6 per ring
                k = int(np.clip(length * self.px_per_unit / 3.0, 6, b - a))
                idx = np.unique(np.linspace(a, b - 1, k).round().astype(np.int64))
                rows.append(idx)
                sp.append((n, n + len(idx), bool(sub.closed)))
                n += len(idx)
            paths.append((art.style, sp))
        idx = np.concatenate(rows) if rows else np.zeros(0, np.int64)
        W = plan.weights(idx)
        M = W if plan.R is None else W @ plan.R
        td = _TemplateDraw(np.ascontiguousarray(M), paths=paths, cols=plan.centres)
        self._templates[index] = td
        return td

    def _groups(self, model) -> list:
        """Elements of ``model`` by template: [(template index, elements, vertex index
        (copies, N_t))], cached per model."""
        key = id(model)
        hit = self._models.get(key)
        if hit is not None and hit[0] is model:
            return hit[1]
        vs, ti = model.elem_vstart, np.asarray(model.template_index)
        groups = []
        for t in np.unique(ti):
            els = np.flatnonzero(ti == t)
            n = int(vs[els[0] + 1] - vs[els[0]])
            groups.append((int(t), els, vs[els][:, None] + np.arange(n)))
        self._models[key] = (model, groups)
        return groups

    def draw_state(self, model, x: np.ndarray, templates: Sequence, unit: float, render_params):
        """A frame (PIL RGB image) of the simulation state ``x`` (N, 2 sim units) of
        ``model``, each element's art mapped through its mesh (one matrix product per
        template for all its copies)."""
        from PIL import ImageDraw  # noqa: PLC0415

        from .placed import similarity_fit  # noqa: PLC0415

        mapped = [None] * model.n_elements  # per element: (template, draw data, pixels, verts)
        for ti, els, idx in self._groups(model):
            t = templates[ti]
            td = self._template(ti, t, render_params)
            verts = np.asarray(x, dtype=float)[idx] * unit  # (copies, N_t, 2)
            q = td.M @ (verts if td.cols is None else verts[:, td.cols])  # (copies, P, 2)
            q = (q - self.origin) * self.px_per_unit
            for k, e in enumerate(els):
                mapped[e] = (t, td, q[k], verts[k])
        img = self._canvas()
        d = ImageDraw.Draw(img)
        for t, td, q, verts in mapped:
            scale = None
            for style, sp in td.paths:
                if style.stroke is not None and scale is None:
                    scale = t.scale * similarity_fit(t.verts, verts)[0]
                self._draw_path(img, d, [q[a:b] for a, b, _ in sp], [c for _, _, c in sp], style,
                                scale or 1.0)
        return self._finish(img)

    def draw_placed(self, placed: Sequence):
        """A frame of finished art (:class:`~repulsionpak.types.PlacedArt` list)."""
        from PIL import ImageDraw  # noqa: PLC0415

        img = self._canvas()
        d = ImageDraw.Draw(img)
        for pa in placed:
            for art in pa.paths:
                self._draw_path(img, d, [self._px(np.asarray(p, float)) for p in art.subpaths],
                                list(art.closed), art.style, pa.stroke_scale)
        return self._finish(img)

    def _finish(self, img):
        return img.reduce(SUPERSAMPLE) if SUPERSAMPLE > 1 else img


# -- recording -------------------------------------------------------------------------------

@dataclass(frozen=True)
class _Frame:
    phase: str
    iteration: int
    model: object
    x: np.ndarray  # float32 copy of the vertices
    pinned: bool  # first (adaptive mode) or last state of a phase: never dropped


@dataclass(frozen=True)
class MovieInfo:
    """What :meth:`MovieRecorder.write` wrote."""

    path: str
    format: str
    frames: int  # frames in the file (GIF: identical neighbours are merged by Pillow)
    fps: float
    seconds: float  # length of the film
    bytes: int
    stride: int  # iterations between frames
    render_seconds: float  # drawing and encoding time


class MovieRecorder:
    """Collects simulation states from snapshots; :meth:`write` makes the film.

    ``every``: iterations between frames (None: adaptive, see the module docstring);
    ``frames``: the adaptive mode's lowest frame count; ``seconds``: the film's length
    aimed at (the frame rate stays within 10–25 frames per second); ``hold``: seconds the
    finished packing is shown at the end; ``size_px``: the frames' longer side.
    """

    def __init__(self, path: str | Path, every: int | None = None, frames: int = 120,
                 seconds: float = 12.0, hold: float = 2.0, size_px: int = 600):
        self.path = Path(path)
        self.format = movie_format(path)
        if every is not None and int(every) < 1:
            raise ParameterError(f"--movie-every must be >= 1, got {every}")
        if not 64 <= int(size_px) <= 4000:
            raise ParameterError(f"movie frame size must be between 64 and 4000 px, got {size_px}")
        if frames < 2 or not seconds > 0 or not hold >= 0:
            raise ParameterError("the movie needs frames >= 2, seconds > 0 and hold >= 0")
        self.every = None if every is None else int(every)
        self.stride = self.every or BASE_EVERY
        self.min_frames, self.seconds, self.hold, self.size_px = int(frames), float(seconds), float(hold), int(size_px)
        self.frames: list[_Frame] = []
        self.capture_seconds = 0.0

    @property
    def snapshot_every(self) -> int:
        """The snapshot cadence the run must have for this recorder (``pack(snapshot_every=)``)."""
        return BASE_EVERY if self.every is None else math.gcd(self.every, BASE_EVERY)

    def __call__(self, snap) -> None:
        if snap.model is None:
            return
        t0 = time.perf_counter()
        last = self.frames[-1] if self.frames else None
        same = last is not None and last.phase == snap.phase and last.iteration == snap.iteration
        if snap.done:
            if same:
                self.frames[-1] = _Frame(last.phase, last.iteration, last.model, last.x, True)
            else:
                self._add(snap, True)
        elif self.every is None and (last is None or last.phase != snap.phase):
            self._add(snap, True)  # adaptive: each phase starts with its first snapshot
        elif snap.iteration % self.stride == 0 and not same:
            self._add(snap, False)
            if self.every is None and len(self.frames) > 2 * self.min_frames:
                self.stride *= 2
                self.frames = [f for f in self.frames if f.pinned or f.iteration % self.stride == 0]
        self.capture_seconds += time.perf_counter() - t0

    def _add(self, snap, pinned: bool) -> None:
        self.frames.append(_Frame(snap.phase, snap.iteration, snap.model,
                                  snap.state.x.astype(np.float32), pinned))

    def timing(self, n: int) -> tuple[int, float]:
        """(GIF delay in centiseconds, frames per second) for ``n`` frames of simulation."""
        delay = int(np.clip(round(100.0 * self.seconds / max(n, 1)), MIN_DELAY_CS, MAX_DELAY_CS))
        return delay, 100.0 / delay

    def write(self, packing, progress: Callable[[int, int], None] | None = None,
              final: bool = True) -> MovieInfo:
        """Draw the recorded frames of ``packing``'s run (and, if ``final``, its finished
        art held for ``hold`` seconds) and write the film atomically.
        ``progress(done, total)`` is called per frame drawn."""
        t0 = time.perf_counter()
        check_movie_output(self.path)
        r = FrameRenderer(packing.container, self.size_px)
        rp = packing.params.render
        unit = packing.frame.unit
        n = len(self.frames) + (1 if final else 0)
        if n == 0:
            raise OutputError(f"{self.path}: no frame was recorded (the run ended before the first snapshot)")
        delay, fps = self.timing(len(self.frames))

        done = [0]

        def tick():
            done[0] += 1
            if progress is not None:
                progress(done[0], n)

        last = r.draw_placed(packing.placed) if final else None  # first: the GIF palette comes from it

        def frames():
            for f in self.frames:
                img = r.draw_state(f.model, f.x, packing.templates, unit, rp)
                tick()
                yield img
            if final:
                tick()
                yield last

        hold_cs = max(delay, round(100 * self.hold)) if final else delay
        if self.format == "gif":
            from ..io.files import atomic_write_bytes  # noqa: PLC0415

            data, count = _gif_bytes(frames(), delay, hold_cs, palette_from=last)
            atomic_write_bytes(self.path, data)
            size = len(data)
            length = ((len(self.frames) - (0 if final else 1)) * delay + hold_cs) / 100.0
        else:
            count = _write_mp4(self.path, frames(), r.size, fps, max(1, round(self.hold * fps)) if final else 1)
            size = self.path.stat().st_size
            length = count / fps
        return MovieInfo(str(self.path), self.format, count, fps, length, size, self.stride,
                         time.perf_counter() - t0)


def _gif_bytes(frames, delay_cs: int, last_cs: int, palette_from=None) -> tuple[bytes, int]:
    """Encode PIL RGB frames as a looping GIF with one palette (from ``palette_from``,
    the finished packing, which holds every colour of the art; else the first frame);
    frames are reduced to it as they come. Returns (bytes, frames in the file)."""
    import io  # noqa: PLC0415

    from PIL import Image  # noqa: PLC0415

    pal = None
    ims = []
    for f in frames:
        if pal is None:
            pal = (palette_from or f).quantize(colors=128, method=Image.Quantize.MEDIANCUT)
        ims.append(f.quantize(palette=pal, dither=Image.Dither.NONE))
    durations = [10 * delay_cs] * (len(ims) - 1) + [10 * last_cs]
    buf = io.BytesIO()
    ims[0].save(buf, format="GIF", save_all=True, append_images=ims[1:], duration=durations,
                loop=0, optimize=True, disposal=1)
    data = buf.getvalue()
    with Image.open(io.BytesIO(data)) as check:
        count = check.n_frames
    return data, count


def _write_mp4(path: Path, frames, size: tuple[int, int], fps: float, hold_frames: int) -> int:
    """Encode frames as H.264 MP4 (yuv420p, plays everywhere; preset veryfast, which is
    faster and here also smaller than the default for these flat-coloured frames)
    through a temp file in the output's directory, then move it into place; returns the
    frame count."""
    import imageio_ffmpeg  # noqa: PLC0415

    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise OutputError(f"{path}: the output directory {parent} does not exist; create it first")
    fd, tmp = tempfile.mkstemp(dir=parent, prefix=f".{path.name}.", suffix=".mp4")
    os.close(fd)
    count = 0
    try:
        w = imageio_ffmpeg.write_frames(tmp, size, fps=fps, codec="libx264", pix_fmt_out="yuv420p",
                                        macro_block_size=2, quality=6,
                                        output_params=["-preset", "veryfast", "-movflags", "+faststart"],
                                        ffmpeg_log_level="error")
        w.send(None)
        last = None
        for img in frames:
            last = np.ascontiguousarray(np.asarray(img, dtype=np.uint8))
            w.send(last)
            count += 1
        for _ in range(hold_frames - 1):
            w.send(last)
            count += 1
        w.close()
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
        tmp = None
    except OSError as exc:
        raise OutputError(f"{path}: cannot write the movie ({exc.strerror or exc})") from None
    except RuntimeError as exc:  # ffmpeg failed
        raise OutputError(f"{path}: ffmpeg could not encode the movie: {exc}") from None
    finally:
        if tmp is not None:
            try:
                os.unlink(tmp)
            except OSError:
                pass
    return count
