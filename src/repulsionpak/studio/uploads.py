"""What the studio accepts from the browser: file names made safe, sizes bounded, and the
library's error messages told with the user's file names (not the session's private paths).
"""

from __future__ import annotations

import re
from pathlib import Path

from ..errors import InputError, ParameterError, RepulsionPakError

#: largest input file accepted (bytes)
MAX_FILE_BYTES = 5 * 2**20
#: largest project archive accepted, and its unpacked contents (bytes)
MAX_PROJECT_BYTES = 50 * 2**20
#: most element files in a session
MAX_ELEMENTS = 200
INPUT_SUFFIXES = (".svg", ".path")


class UploadTooLarge(ParameterError):
    """An uploaded file or project is larger than the studio accepts."""


def safe_name(name: str, suffixes=INPUT_SUFFIXES) -> str:
    """A file name of the user's safe to create in the session folder: the last path
    component, other characters than letters, digits, ``.``, ``-``, ``_`` replaced by
    ``_``; raises :class:`ParameterError` for a suffix other than ``suffixes``."""
    base = re.split(r"[\\/]", str(name))[-1]
    base = re.sub(r"[^A-Za-z0-9._-]", "_", base).lstrip(".") or "file"
    if not base.lower().endswith(tuple(suffixes)):
        raise ParameterError(f"{name}: not an input file the studio reads (expected {' or '.join(suffixes)})")
    return base[:120]


def named_error(exc: RepulsionPakError, path: Path, name: str) -> RepulsionPakError:
    """``exc`` with the session's private path of a file replaced by the file's name."""
    def swap(text):
        return None if text is None else str(text).replace(str(path), name)

    if isinstance(exc, InputError):
        return InputError(swap(exc.path), swap(exc.problem))
    try:
        return type(exc)(swap(str(exc)))
    except TypeError:  # an error class of other arguments: as it is
        return exc


def check_size(name: str, size: int, limit: int = MAX_FILE_BYTES) -> None:
    """Refuse a file of ``size`` bytes over ``limit`` with :class:`UploadTooLarge`."""
    if size > limit:
        raise UploadTooLarge(f"{name}: the file is {size / 2**20:.1f} MB; the studio accepts files of "
                             f"up to {limit / 2**20:.0f} MB")


__all__ = ["INPUT_SUFFIXES", "MAX_ELEMENTS", "MAX_FILE_BYTES", "MAX_PROJECT_BYTES", "UploadTooLarge",
           "check_size", "named_error", "safe_name"]
