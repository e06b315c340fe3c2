"""What the designer edits, and the undo/redo stack of those edits.

A :class:`Document` is immutable: the container file, the brush strokes, the element
files, the settings and the flow guides. Every edit makes a new document and pushes an :class:`Edit`
record (the documents before and after, and for edits of the running simulation — a pin,
a drag — the commands that redo and undo it). Undo and redo move along that stack; a new
edit after an undo drops the redo side, as editors do.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

from .region import Stroke
from .settings import DEFAULTS

#: most edits kept for undo
MAX_HISTORY = 500


@dataclass(frozen=True)
class InputFile:
    """An input file of the studio: ``name`` as the project and the command line call it,
    ``path`` where it lies (the session's private folder); ``weight``: an element's relative
    frequency among the free copies (the element manifest's ``weight``); ``own``: the
    element's own settings, (key, value) pairs of
    :data:`~.settings.ELEMENT_KEYS` that override the run's (an element manifest's keys)."""

    name: str
    path: Path
    weight: float = 1.0
    own: tuple[tuple[str, object], ...] = ()

    @property
    def own_dict(self) -> dict:
        return dict(self.own)

    @property
    def in_manifest(self) -> bool:
        """Whether the element needs a manifest entry (a weight other than 1, own settings)."""
        return self.weight != 1.0 or bool(self.own)


@dataclass(frozen=True)
class Document:
    """The studio's inputs: what a project saves and a run packs."""

    container: InputFile | None = None
    strokes: tuple[Stroke, ...] = ()
    elements: tuple[InputFile, ...] = ()
    secondary: tuple[InputFile, ...] = ()  # the pockets' elements (``--secondary``)
    settings: tuple[tuple[str, object], ...] = tuple(DEFAULTS.items())
    guides: tuple[tuple[tuple[float, float], ...], ...] = ()  # flow guides, in the order drawn (``--flow``)

    @property
    def settings_dict(self) -> dict:
        return dict(self.settings)

    def with_settings(self, **changes) -> "Document":
        s = self.settings_dict
        s.update(changes)
        return replace(self, settings=tuple(s.items()))


@dataclass(frozen=True)
class Edit:
    """One step of the history. ``redo_cmd``/``undo_cmd``: simulation commands (the live
    view's protocol) that redo/undo an edit of the running simulation; None for edits of
    the document alone."""

    label: str
    before: Document
    after: Document
    redo_cmd: dict | None = None
    undo_cmd: dict | None = None


@dataclass
class History:
    """The undo/redo stack over documents."""

    doc: Document = field(default_factory=Document)
    done: list[Edit] = field(default_factory=list)
    undone: list[Edit] = field(default_factory=list)

    def push(self, label: str, after: Document, redo_cmd: dict | None = None,
             undo_cmd: dict | None = None) -> Edit:
        """Record an edit that made ``after`` of the current document; returns it."""
        e = Edit(label, self.doc, after, redo_cmd, undo_cmd)
        self.done.append(e)
        del self.done[:-MAX_HISTORY]
        self.undone.clear()
        self.doc = after
        return e

    def undo(self) -> Edit | None:
        """Step back one edit (None when there is none); the document becomes its ``before``."""
        if not self.done:
            return None
        e = self.done.pop()
        self.undone.append(e)
        self.doc = e.before
        return e

    def redo(self) -> Edit | None:
        """Step forward one undone edit (None when there is none)."""
        if not self.undone:
            return None
        e = self.undone.pop()
        self.done.append(e)
        self.doc = e.after
        return e

    def replace_current(self, doc: Document) -> None:
        """Change the current document without an undo step (a drawn seed recorded)."""
        self.doc = doc

    def state(self) -> dict:
        return {"can_undo": bool(self.done), "can_redo": bool(self.undone),
                "undo_label": self.done[-1].label if self.done else None,
                "redo_label": self.undone[-1].label if self.undone else None}


__all__ = ["Document", "Edit", "History", "InputFile", "MAX_HISTORY"]
