"""One designer's studio session: the inputs, their edits, the run and what comes out.

The session keeps every input file in a private temporary folder (mode 0700) and reads it
with the library's hardened readers (:func:`repulsionpak.load_container`,
:func:`repulsionpak.load_elements`), so an uploaded file is checked as a file given to
``repulsionpak pack`` is. A run reads its inputs through :func:`repulsionpak.inputs.load_inputs`
and packs with :func:`repulsionpak.pack` in a thread of its own, steered by the
:class:`~.controller.StudioController`; its exports are the :class:`repulsionpak.Packing`'s
own writers, so a finished run exports the bytes ``repulsionpak pack`` writes for the same
inputs, options and seed (:meth:`Session.command` says which command that is).
"""

from __future__ import annotations

import dataclasses
import re
import secrets
import shutil
import tempfile
import threading
from pathlib import Path

import shapely

from ..errors import ParameterError, RepulsionPakError
from .controller import StudioController
from .document import Document, History, InputFile
from .guides import GUIDES_NAME, MAX_GUIDES, guides_field, guides_svg, parse_guide
from .project import read_project, write_project
from .region import Stroke, painted_region, region_svg, rings_of
from .settings import coerce, coerce_element, command_line, element_manifest, run_settings
from .uploads import MAX_ELEMENTS, check_size, named_error, safe_name

#: the canvas of a session without a container file (container units)
BLANK_CANVAS = (0.0, 0.0, 1000.0, 1000.0)
#: the name of a painted container, in a project and on the command line
PAINTED_NAME = "container.svg"
#: the element manifest of weighted elements, in a project and on the command line
ELEMENTS_MANIFEST = "elements.toml"


def weighted(doc: Document) -> bool:
    """Whether ``doc``'s elements need a manifest (a weight other than 1, or an element's
    own settings)."""
    return any(e.in_manifest for e in doc.elements)


class Session:
    """The studio's state. Thread-safe: the server calls it from worker threads."""

    def __init__(self):
        self.dir = Path(tempfile.mkdtemp(prefix="repulsionpak-studio-"))  # mode 0700
        self.history = History()
        self.controller = StudioController(BLANK_CANVAS)
        self.lock = threading.RLock()
        self.packing = None  # the last finished run's Packing
        self.packing_doc: Document | None = None  # the document it was made from
        self.error: str | None = None
        self._thread: threading.Thread | None = None
        self._gen = 0  # the run whose callbacks and result count
        self._result_lock = threading.Lock()  # the run's result against a new run
        self._callback_lock = threading.Lock()  # a run's call into the controller against a reset
        self._n_files = 0
        self._containers: dict[Path, object] = {}
        self._painted: dict[tuple, tuple[Path, object]] = {}
        self._guide_files: dict[tuple, Path] = {}
        self._fields: dict[tuple, str] = {}

    @property
    def doc(self) -> Document:
        return self.history.doc

    def close(self) -> None:
        """End any run and delete the session's files."""
        self.cancel(wait=5.0)
        shutil.rmtree(self.dir, ignore_errors=True)

    # -- inputs ------------------------------------------------------------------------------
    def _store(self, name: str, data: bytes) -> Path:
        check_size(name, len(data))
        self._n_files += 1
        d = self.dir / "files" / f"{self._n_files:05d}"
        d.mkdir(parents=True)
        path = d / name
        path.write_bytes(data)
        return path

    def _read_container(self, path: Path, name: str):
        from .. import load_container

        if path not in self._containers:
            try:
                self._containers[path] = load_container(path)
            except RepulsionPakError as exc:
                raise named_error(exc, path, name) from None
        return self._containers[path]

    def open_container(self, name: str, data: bytes) -> dict:
        """Make the file ``name`` (contents ``data``) the container; the strokes painted
        so far are dropped (they belong to the canvas of the container before)."""
        with self.lock:
            name = safe_name(name)
            path = self._store(name, data)
            try:
                self._read_container(path, name)
            except RepulsionPakError:
                shutil.rmtree(path.parent, ignore_errors=True)
                raise
            self._edit(f"open {name}", dataclasses.replace(self.doc, container=InputFile(name, path), strokes=()))
            return self.state()

    def add_elements(self, files: list[tuple[str, bytes]], secondary: bool = False) -> dict:
        """Add element files (name, contents), or secondary ones (the pockets' elements,
        ``--secondary``); each is read as ``repulsionpak pack`` reads it.

        A name may be a path relative to a chosen folder (``animals/cat.svg``): its input
        files are added and the others left out. An element manifest (``.toml``) among
        them adds the files it names with its weights and per-element keys (see
        :func:`repulsionpak.studio.manifests.manifest_elements`), and only those."""
        names = [str(n) for n, _ in files]
        if any(n.lower().endswith(".toml") for n in names) or any(("/" in n or "\\" in n) for n in names):
            return self._add_tree(files, secondary)
        return self._add_files([(n, d, 1.0, ()) for n, d in files], secondary)

    def _add_tree(self, files: list[tuple[str, bytes]], secondary: bool) -> dict:
        """A folder's files, or manifests with the files they name."""
        from .manifests import is_input, manifest_elements, store_tree

        with self.lock:
            self._n_files += 1
            folder = self.dir / "trees" / f"{self._n_files:05d}"
            folder.mkdir(parents=True)
        rels = store_tree(folder, files)
        manifests = [r for r in rels if r.suffix.lower() == ".toml"]
        if manifests and secondary:
            raise ParameterError("secondary elements take no manifest: give their SVG files")
        if manifests:
            inputs = [r for r in rels if is_input(r)]
            chosen = [e for m in manifests for e in manifest_elements(folder, m, inputs)]
            entries = [(f.name, (folder / f).read_bytes(), w, tuple(sorted(own.items()))) for f, w, own in chosen]
        else:
            entries = [(r.name, (folder / r).read_bytes(), 1.0, ()) for r in rels if is_input(r)]
            if not entries:
                raise ParameterError("no SVG or .path files among those given")
        return self._add_files(entries, secondary)

    def _add_files(self, files: list[tuple[str, bytes, float, tuple]], secondary: bool) -> dict:
        from .. import load_elements

        field = "secondary" if secondary else "elements"
        with self.lock:
            current = getattr(self.doc, field)
            have = {e.name for e in current}
            if len(have) + len(files) > MAX_ELEMENTS:
                raise ParameterError(f"the studio takes at most {MAX_ELEMENTS} {field} files")
            added = []
            for name, data, weight, own in files:
                name = safe_name(name)
                stem, dot, ext = name.rpartition(".")
                k = 2
                while name in have:
                    name, k = f"{stem}-{k}.{ext}", k + 1
                path = self._store(name, data)
                try:
                    load_elements([path])
                except RepulsionPakError as exc:
                    shutil.rmtree(path.parent, ignore_errors=True)
                    raise named_error(exc, path, name) from None
                have.add(name)
                added.append(InputFile(name, path, weight, own))
            if added:
                label = f"add {added[0].name}" + (f" and {len(added) - 1} more" if len(added) > 1 else "")
                self._edit(label, dataclasses.replace(self.doc, **{field: current + tuple(added)}))
            return self.state()

    def remove_element(self, index: int, secondary: bool = False) -> dict:
        """Take element file ``index`` (of the secondary ones: ``secondary``) out."""
        field = "secondary" if secondary else "elements"
        with self.lock:
            els = list(getattr(self.doc, field))
            if not 0 <= index < len(els):
                raise ParameterError(f"no {field} file {index}")
            gone = els.pop(index)
            self._edit(f"remove {gone.name}", dataclasses.replace(self.doc, **{field: tuple(els)}))
            return self.state()

    def use_examples(self, container: str | None = None, elements: list[str] | None = None) -> dict:
        """Open a shipped example container and/or example elements (by stem; ``elements``
        empty: all of them)."""
        from .. import examples

        with self.lock:
            if container is not None:
                if container not in examples.container_names():
                    raise ParameterError(f"no example container {container!r}; the examples are "
                                         f"{', '.join(examples.container_names())}")
                p = examples.container_file(container)
                self.open_container(p.name, p.read_bytes())
            if elements is not None:
                files = {p.stem: p for p in examples.element_files()}
                wanted = elements or sorted(files)
                bad = [w for w in wanted if w not in files]
                if bad:
                    raise ParameterError(f"no example element {bad[0]!r}; the examples are {', '.join(sorted(files))}")
                self.add_elements([(files[w].name, files[w].read_bytes()) for w in wanted])
            return self.state()

    # -- edits ---------------------------------------------------------------------------------
    def _edit(self, label: str, after: Document, redo_cmd=None, undo_cmd=None) -> None:
        before = self.doc
        self.history.push(label, after, redo_cmd, undo_cmd)
        self._apply_change(before, after)

    def _apply_change(self, before: Document, after: Document) -> None:
        """Show the new document; a changed region reaches a running simulation at once
        (changed guides apply to the next run)."""
        if before.guides != after.guides and self.running:
            self.controller.publish("json", {"type": "error", "message": "the flow guides apply when you "
                                             "start again"})
        if (before.container, before.strokes) == (after.container, after.strokes):
            return
        if after.container != before.container:
            if self.running:  # another file: another drawing, not an edit of this run's room
                self.cancel()
                self.controller.clear()
            self._set_canvas(after)
        cont = self.container_of(after)
        if self.running and self.controller.takes_region and cont is not None:
            self.controller.submit({"cmd": "region", "container": cont})
        elif not self.running:
            self.controller.show(cont)
        else:  # a run past its primary phase keeps its region
            self.controller.publish("json", {"type": "error", "message": "the run has passed its primary "
                                             "phase: the new region applies when you start again"})

    def _set_canvas(self, doc: Document) -> None:
        """The page's canvas: the container file's view box, widened to hold its region
        with a margin to paint in; the blank canvas without a file."""
        if doc.container is None:
            self.controller.view_box = list(BLANK_CANVAS)
            return
        c = self._read_container(doc.container.path, doc.container.name)
        minx, miny, maxx, maxy = c.bounds
        vb = c.svg_root.get("viewBox") if isinstance(c.svg_root, dict) else None
        try:
            x, y, w, h = (float(v) for v in re.split(r"[\s,]+", vb.strip()))
            minx, miny, maxx, maxy = min(minx, x), min(miny, y), max(maxx, x + w), max(maxy, y + h)
        except (AttributeError, ValueError):
            pass
        pad = 0.1 * max(maxx - minx, maxy - miny)
        self.controller.view_box = [minx - pad, miny - pad, maxx - minx + 2 * pad, maxy - miny + 2 * pad]

    def stroke(self, msg: object) -> dict:
        """Paint or erase one brush stroke (see :meth:`repulsionpak.studio.region.Stroke.parse`)."""
        s = Stroke.parse(msg)
        with self.lock:
            self._edit("paint" if s.mode == "paint" else "erase", dataclasses.replace(
                self.doc, strokes=self.doc.strokes + (s,)))
            return self.state()

    def guide(self, msg: object) -> dict:
        """Add a flow guide stroke (``{"points": [[x, y], ...]}``, container units, in the
        direction of travel); the run follows the field of the guides (``--flow``)."""
        g = parse_guide(msg)
        with self.lock:
            if len(self.doc.guides) >= MAX_GUIDES:
                raise ParameterError(f"the studio takes at most {MAX_GUIDES} flow guides")
            self._edit("guide", dataclasses.replace(self.doc, guides=self.doc.guides + (g,)))
            return self.state()

    def clear_guides(self) -> dict:
        """Take every flow guide out (undoable)."""
        with self.lock:
            if self.doc.guides:
                self._edit("clear guides", dataclasses.replace(self.doc, guides=()))
            return self.state()

    def guides_file(self, doc: Document) -> Path | None:
        """The guide SVG a run of ``doc`` reads (``--flow``); None without guides."""
        if not doc.guides:
            return None
        key = (doc.guides, tuple(self.controller.view_box))
        if key not in self._guide_files:
            d = self.dir / "guides" / f"{len(self._guide_files):05d}"
            d.mkdir(parents=True)
            path = d / GUIDES_NAME
            path.write_text(guides_svg(doc.guides, self.controller.view_box), encoding="utf-8")
            self._guide_files[key] = path
        return self._guide_files[key]

    def field_path(self, doc: Document) -> str:
        """The arrows of ``doc``'s flow field inside its container, as the page draws
        them ('' without guides or container)."""
        region = self.region_of(doc)
        if not doc.guides or region.is_empty:
            return ""
        key = (doc.guides, region.wkb)
        if key not in self._fields:
            from ..live.field_layer import field_path

            self._fields.clear()  # (one at a time: the current document's)
            self._fields[key] = field_path(guides_field(doc.guides, region.bounds), region)
        return self._fields[key]

    def set_setting(self, name: str, value: object) -> dict:
        """Change one setting; refused (nothing changes) with the CLI's message when the
        settings together are not a valid run."""
        with self.lock:
            v = coerce(name, value)
            after = self.doc.with_settings(**{name: v})
            run_settings(after.settings_dict)
            if after.settings != self.doc.settings:
                self._edit(f"{name} = {v}", after)
            return self.state()

    def pin(self, index: int, pinned: bool) -> dict:
        """Pin or unpin element ``index`` of the running simulation (undoable)."""
        with self.lock:
            cmd = {"cmd": "pin", "index": int(index), "pinned": bool(pinned)}
            self.controller.submit(cmd)
            self.history.push(("pin" if pinned else "unpin") + f" element {index}", self.doc, cmd,
                              dict(cmd, pinned=not pinned))
            return self.state()

    def remove(self, index: int) -> dict:
        """Remove element ``index`` from the running simulation (undoable: it comes back
        where it was)."""
        with self.lock:
            cmd = {"cmd": "remove", "index": int(index)}
            self.controller.submit(cmd)
            self.history.push(f"remove element {index}", self.doc, cmd, dict(cmd, cmd="unremove"))
            return self.state()

    def add_copy(self, index: int, x: float, y: float, timeout: float = 60.0) -> dict:
        """Add a copy of element ``index`` of the running simulation growing at (x, y)
        (container units); undoable: undo removes the copy, redo puts it back where it
        was. A copy the run refuses (outside the container, a frozen element) is told to
        the page and leaves no history."""
        from concurrent.futures import Future
        from concurrent.futures import TimeoutError as FutureTimeout

        from ..live.protocol import parse_command

        try:
            cmd = parse_command({"cmd": "add", "index": int(index), "x": float(x), "y": float(y)})
        except ValueError as exc:
            raise ParameterError(str(exc)) from None
        if not self.running:
            raise ParameterError("add a copy while a run goes on: press Start")
        fut: Future = Future()
        self.controller.submit(dict(cmd, future=fut))
        try:
            new = fut.result(timeout=timeout)
        except FutureTimeout:
            raise ParameterError("the run did not take the copy in time") from None
        except RuntimeError as exc:  # the run was restarted meanwhile
            raise ParameterError(str(exc)) from None
        with self.lock:
            if new is not None:
                self.history.push(f"add a copy of element {index}", self.doc,
                                  {"cmd": "unremove", "index": new}, {"cmd": "remove", "index": new})
            return self.state()

    def moved(self, index: int, dx: float, dy: float) -> dict:
        """Record a drag the page made (it moved the element itself): undo moves it back."""
        with self.lock:
            cmd = {"cmd": "move", "index": int(index), "dx": float(dx), "dy": float(dy)}
            self.history.push(f"move element {index}", self.doc, cmd, dict(cmd, dx=-cmd["dx"], dy=-cmd["dy"]))
            return self.state()

    def undo(self) -> dict:
        with self.lock:
            e = self.history.undo()
            if e is not None:
                if e.undo_cmd is not None and self.running:
                    self.controller.submit(e.undo_cmd)
                self._apply_change(e.after, e.before)
            return self.state()

    def redo(self) -> dict:
        with self.lock:
            e = self.history.redo()
            if e is not None:
                if e.redo_cmd is not None and self.running:
                    self.controller.submit(e.redo_cmd)
                self._apply_change(e.before, e.after)
            return self.state()

    # -- the container ---------------------------------------------------------------------------
    def region_of(self, doc: Document) -> shapely.Geometry:
        base = None if doc.container is None else self._read_container(doc.container.path, doc.container.name).region
        if not doc.strokes:
            return shapely.Polygon() if base is None else base
        vb = self.controller.view_box
        return painted_region(base, doc.strokes, min_area=1e-6 * vb[2] * vb[3])

    def container_file(self, doc: Document) -> InputFile | None:
        """The container file a run reads: the opened file, or (strokes painted) the
        painted region written as an SVG file; None when there is no region."""
        if not doc.strokes:
            return doc.container
        key = (doc.container, doc.strokes)
        if key not in self._painted:
            region = self.region_of(doc)
            if region.is_empty:
                return None
            d = self.dir / "painted" / f"{len(self._painted):05d}"
            d.mkdir(parents=True)
            path = d / PAINTED_NAME
            path.write_text(region_svg(region, self.controller.view_box), encoding="utf-8")
            self._painted[key] = (path, None)
        return InputFile(PAINTED_NAME, self._painted[key][0])

    def container_of(self, doc: Document):
        """The :class:`repulsionpak.Container` of ``doc`` as read from its file (None: no region)."""
        f = self.container_file(doc)
        return None if f is None else self._read_container(f.path, f.name)

    # -- the run -------------------------------------------------------------------------------------
    @property
    def running(self) -> bool:
        return self._thread is not None and self._thread.is_alive() and not self.controller.cancelled

    def start(self, new_seed: bool = False, paused: bool = False) -> dict:
        """Start a run of the current document (``new_seed``: with a seed drawn anew; a
        run in progress is ended first). A paused run is resumed instead, unless ``new_seed``."""
        with self.lock:
            if self.running and not new_seed:
                self.controller.submit({"cmd": "resume"})
                return self.state()
            doc = self.doc
            if new_seed or doc.settings_dict["seed"] is None:  # the command line names the seed
                doc = doc.with_settings(seed=secrets.randbelow(2**31))
                self.history.replace_current(doc)
            params, controls = run_settings(doc.settings_dict)
            cfile = self.container_file(doc)
            if cfile is None:
                raise ParameterError("there is no container: open a container file or paint one with the brush")
            if not doc.elements:
                raise ParameterError("there are no elements: open element files or take the examples")
            from ..inputs import load_inputs

            inputs = load_inputs(cfile.path, self._element_args(doc), params,
                                 secondary=[e.path for e in doc.secondary], controls=controls)
            self.cancel()
            self.controller.reset(inputs.container, inputs.params, paused=paused)
            with self._result_lock:
                self.packing, self.packing_doc, self.error = None, None, None
                self._gen += 1
                gen = self._gen
            flow = self.guides_file(doc)
            self._thread = threading.Thread(target=self._run, args=(gen, inputs, doc, flow),
                                            name="repulsionpak-studio-run", daemon=True)
            self._thread.start()
            return self.state()

    def cancel(self, wait: float = 0.0) -> None:
        """End the run in progress (its result is thrown away).

        Returns once the run no longer calls the controller (a call in progress, such as
        a pause, has returned): a new run may reset it. The old run's last stages (the
        art, the verification) may still be working in its thread, ``wait`` seconds at
        most are spent waiting for them; they end unseen."""
        t = self._thread
        if t is None or not t.is_alive():
            return
        with self._result_lock:
            self._gen += 1
        self.controller.cancel()
        with self._callback_lock:  # the run's callback in progress has returned
            pass
        t.join(wait)

    def _run(self, gen: int, inputs, doc: Document, flow: Path | None = None) -> None:
        """The run's thread: :func:`repulsionpak.pack` with the controller's callbacks,
        inert once the run was cancelled (``gen`` is no longer the session's)."""
        from .. import pack

        ctl = self.controller

        def guarded(fn, stopped=None):
            def call(*args):
                with self._callback_lock:
                    return fn(*args) if gen == self._gen else stopped
            return call

        try:
            packing = pack(inputs.container, list(inputs.elements), inputs.params,
                           secondary=list(inputs.secondary), on_snapshot=guarded(ctl.on_snapshot),
                           should_stop=guarded(ctl.should_stop, True), on_stage=guarded(ctl.on_stage),
                           flow=flow)
            with self._callback_lock:
                if gen != self._gen:
                    return
                packing.placed = ctl.drop_removed(packing.placed)  # as `pack --live` writes it
            text = packing.svg_text()
            m = packing.metrics(distortion=False)
            with self._result_lock, self._callback_lock:
                if gen != self._gen:
                    return
                self.packing, self.packing_doc = packing, doc
                ctl.finish(text, dict(packing.stopped_by), m["area_fraction"], m["gap"]["median"])
        except Exception as exc:  # noqa: BLE001  (told to the page; the session goes on)
            with self._result_lock:
                if gen != self._gen:
                    return
                self.error = str(exc) if isinstance(exc, RepulsionPakError) else f"{type(exc).__name__}: {exc}"
                ctl.phase = "failed"
                ctl.publish("json", {"type": "error", "message": self.error})
                ctl.publish("json", dict(ctl.status(), phase="failed"))

    # -- out ---------------------------------------------------------------------------------------
    def export(self, kind: str) -> bytes:
        """The packing as ``svg``, ``pdf`` or ``png``: the finished run's through the
        packing's writers (what ``repulsionpak pack`` writes), a running one's as the live
        view draws it (partial)."""
        if kind not in ("svg", "pdf", "png"):
            raise ParameterError(f"cannot export {kind!r}; use svg, pdf or png")
        packing = self.packing
        if packing is not None:
            if kind == "svg":
                return packing.svg_text().encode("utf-8")
            if kind == "png":
                return packing.png_bytes()
            from ..render.pdf import pdf_bytes

            return pdf_bytes(packing.svg_text(), "packing.pdf")
        if not self.running or self.controller.sim is None:
            raise ParameterError("nothing to export yet: start a run first")
        if kind == "png":
            return self._running_png()
        text = self.controller.render_svg()
        if kind == "svg":
            return text.encode("utf-8")
        from ..render.pdf import pdf_bytes

        return pdf_bytes(text, "packing.pdf")

    def _running_png(self) -> bytes:
        from concurrent.futures import Future

        from ..render.png import png_bytes

        ctl = self.controller
        fut: Future = Future()
        ctl.commands.put({"cmd": "placed", "future": fut})
        placed = fut.result(timeout=120)
        return png_bytes(ctl.container, placed, 1200, container_paint=ctl.container_paint, gap=ctl.gap)

    def _element_args(self, doc: Document) -> list[Path]:
        """The element arguments of a run: the files, or (some weight is not 1) an element
        manifest naming them with their weights, as the project's ``elements.toml``."""
        if not weighted(doc):
            return [e.path for e in doc.elements]
        self._n_files += 1
        d = self.dir / "manifests" / f"{self._n_files:05d}"
        d.mkdir(parents=True)
        path = d / ELEMENTS_MANIFEST
        path.write_text(element_manifest([(e.path, e.weight, e.own) for e in doc.elements]), encoding="utf-8")
        return [path]

    def command(self, doc: Document | None = None) -> str | None:
        """The ``repulsionpak pack`` command that makes ``doc``'s packing, with the files
        named as a saved project holds them (None: no container or no elements)."""
        doc = doc or self.doc
        cfile = self.container_file(doc) if (doc.container or doc.strokes) else None
        if cfile is None or not doc.elements:
            return None
        elements = [ELEMENTS_MANIFEST] if weighted(doc) else [f"elements/{e.name}" for e in doc.elements]
        return command_line(doc.settings_dict, cfile.name, elements,
                            secondary=[f"secondary/{e.name}" for e in doc.secondary],
                            flow=GUIDES_NAME if doc.guides else None)

    def set_weight(self, index: int, value: object) -> dict:
        """Element ``index``'s weight (relative frequency of its free copies; 0: none),
        checked as an element manifest's ``weight`` is."""
        from ..types import ElementControls

        with self.lock:
            els = list(self.doc.elements)
            if not 0 <= index < len(els):
                raise ParameterError(f"no element file {index}")
            try:
                w = float(value)
            except (TypeError, ValueError):
                raise ParameterError(f"weight must be a number, got {value!r}") from None
            ElementControls(weight=w)  # its check and message
            if w != els[index].weight:
                els[index] = dataclasses.replace(els[index], weight=w)
                self._edit(f"weight of {els[index].name} = {w:g}", dataclasses.replace(self.doc, elements=tuple(els)))
            return self.state()

    def set_element(self, index: int, key: str, value: object) -> dict:
        """Element ``index``'s own setting ``key`` (``rotation`` as ``--rotation`` gives it,
        ``rigid``, ``stiffness``; empty: the run's setting), checked as an element
        manifest's keys are; the run reads it through the element manifest."""
        with self.lock:
            els = list(self.doc.elements)
            if not 0 <= index < len(els):
                raise ParameterError(f"no element file {index}")
            v = coerce_element(key, value)
            own = {k: x for k, x in els[index].own if k != key}
            if v is not None:
                own[key] = v
            own_t = tuple(sorted(own.items()))
            if own_t != els[index].own:
                els[index] = dataclasses.replace(els[index], own=own_t)
                label = f"{key} of {els[index].name} = " + ("the run's" if v is None else str(v))
                self._edit(label, dataclasses.replace(self.doc, elements=tuple(els)))
            return self.state()

    def project_zip(self) -> bytes:
        """The project (see :func:`repulsionpak.studio.project.write_project`)."""
        with self.lock:
            doc = self.doc
            return write_project(doc, self.container_file(doc), self.command(doc),
                                 ELEMENTS_MANIFEST if weighted(doc) else None, self.guides_file(doc))

    def open_project(self, data: bytes) -> dict:
        """Open a project saved by :meth:`project_zip` (one undoable edit); every file is
        read as an opened one is, every setting checked."""
        project = read_project(data)
        with self.lock:
            doc = Document(settings=tuple(project.settings.items()), guides=tuple(project.guides))
            if project.container is not None:
                name, content = project.container
                path = self._store(safe_name(name), content)
                self._read_container(path, name)
                doc = dataclasses.replace(doc, container=InputFile(path.name, path))
            from .. import load_elements

            for field in ("elements", "secondary"):
                files = []
                weights = project.weights if field == "elements" else [1.0] * len(project.secondary)
                owns = project.own if field == "elements" else [{}] * len(project.secondary)
                for (name, content), weight, own in zip(getattr(project, field), weights, owns):
                    path = self._store(safe_name(name), content)
                    try:
                        load_elements([path])
                    except RepulsionPakError as exc:
                        raise named_error(exc, path, name) from None
                    files.append(InputFile(path.name, path, weight, tuple(sorted(own.items()))))
                doc = dataclasses.replace(doc, **{field: tuple(files)})
            self._edit("open project", doc)
            return self.state()

    # -- what the page shows ---------------------------------------------------------------------------
    def state(self) -> dict:
        """The document as the page shows it (JSON)."""
        doc = self.doc
        region = self.region_of(doc)
        st = self.controller.status()
        return {
            "container": None if doc.container is None else doc.container.name,
            "painted": bool(doc.strokes),
            "region": rings_of(region),
            "region_area": float(region.area),
            "view_box": list(self.controller.view_box),
            "elements": [e.name for e in doc.elements],
            "weights": [e.weight for e in doc.elements],
            "own": [e.own_dict for e in doc.elements],
            "secondary": [e.name for e in doc.secondary],
            "settings": doc.settings_dict,
            "guides": [[list(p) for p in g] for g in doc.guides],
            "field": self.field_path(doc),
            "command": self.command(doc),
            "history": self.history.state(),
            "running": self.running,
            "paused": bool(st.get("paused")),
            "phase": st.get("phase"),
            "finished": self.packing is not None,
            "error": self.error,
        }


__all__ = ["BLANK_CANVAS", "ELEMENTS_MANIFEST", "PAINTED_NAME", "Session", "weighted"]
