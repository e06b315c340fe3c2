"""Input and output files: the limits every reader applies, and the atomic writer.

Owns reading a whole input file (size bound, ``.svgz`` decompression, missing / empty /
unreadable files as :class:`~repulsionpak.errors.InputError`), telling an SVG from a
RepulsionPak ``.path`` file, the per-file point budget (:class:`PointBudget`), the
coordinate range check, the :func:`guard` that turns any unexpected failure of a reader
into an InputError naming the file, reader warnings that name the file, and
:func:`atomic_write_bytes`, which every output (SVG, PDF, PNG, reports, checkpoints)
is written with.

Notes
-----
Readers of SVG, ``.path`` and packing files and every writer need these, so they sit at
the bottom of ``io`` and import nothing from it: ``render`` imports this module, never the
readers.
"""

from __future__ import annotations

import contextlib
import gzip
import io
import math
import os
import re
import tempfile
import warnings
import zlib
from pathlib import Path

import numpy as np

from ..errors import InputError, OutputError, RepulsionPakError

__all__ = [
    "MAX_COORD",
    "MAX_FILE_BYTES",
    "MAX_POINTS",
    "PointBudget",
    "TooManyPoints",
    "atomic_write_bytes",
    "check_coordinates",
    "guard",
    "read_input_bytes",
    "sniff_kind",
    "warn",
]


#: Largest input file accepted (bytes, after gzip decompression for ``.svgz``).
MAX_FILE_BYTES = 128 * 1024 * 1024
#: Largest number of vertices a file may produce after flattening its curves.
MAX_POINTS = 2_000_000
#: Largest absolute coordinate (file user units) accepted: beyond it areas and squared
#: distances lose all precision or overflow (1e300 squared is infinite).
MAX_COORD = 1e15
_SVG_SUFFIXES = {".svg", ".svgz", ".xml"}


def warn(path: str | Path, message: str) -> None:
    """``warnings.warn`` (UserWarning) with the file name in front."""
    warnings.warn(f"{Path(str(path)).name}: {message}", UserWarning, stacklevel=3)


@contextlib.contextmanager
def guard(path: str | Path, what: str = "file"):
    """Turn any unexpected exception raised in the block into an InputError naming ``path``."""
    try:
        yield
    except RepulsionPakError:
        raise
    except RecursionError:
        raise InputError(
            path, f"the {what} is nested too deeply to be read; simplify its structure"
        ) from None
    except MemoryError:
        raise InputError(
            path, f"the {what} is too large to be read into memory; simplify it"
        ) from None
    except Exception as exc:
        text = str(exc).strip()
        detail = (
            f"{type(exc).__name__}: {text.splitlines()[0][:200]}"
            if text
            else type(exc).__name__
        )
        raise InputError(
            path, f"the {what} could not be read ({detail}); check that it is valid"
        ) from exc


def read_input_bytes(path: str | Path, what: str = "file") -> bytes:
    """Read a whole input file with the checks every reader needs.

    Missing file, directory, unreadable or empty file, or a file larger than
    :data:`MAX_FILE_BYTES` -> InputError. gzip data (``.svgz``) is decompressed under
    the same size bound.
    """
    p = Path(path)
    try:
        exists, is_dir = p.exists(), p.is_dir()
    except (OSError, ValueError) as exc:
        raise InputError(
            p, f"cannot access the {what} ({exc}); check the path"
        ) from None
    if not exists:
        raise InputError(p, f"{what} not found; check the path")
    if is_dir:
        raise InputError(p, "is a directory, not a file; give a file")
    try:
        with open(p, "rb") as fh:
            data = fh.read(MAX_FILE_BYTES + 1)
    except OSError as exc:
        raise InputError(
            p,
            f"the {what} cannot be read ({exc.strerror or exc}); check its permissions",
        ) from None
    if len(data) > MAX_FILE_BYTES:
        raise InputError(
            p, f"the {what} is larger than {MAX_FILE_BYTES} bytes; simplify it"
        )
    if data[:2] == b"\x1f\x8b":
        try:
            with gzip.GzipFile(fileobj=io.BytesIO(data)) as gz:
                data = gz.read(MAX_FILE_BYTES + 1)
        except (OSError, EOFError, zlib.error) as exc:
            raise InputError(
                p, f"looks gzip-compressed but cannot be decompressed ({exc})"
            ) from None
        if len(data) > MAX_FILE_BYTES:
            raise InputError(
                p, f"decompresses to more than {MAX_FILE_BYTES} bytes; simplify it"
            )
    if not data.strip():
        raise InputError(
            p, f"the {what} is empty; give an SVG or .path file with geometry"
        )
    return data


def sniff_kind(path: Path, data: bytes) -> str:
    """``"path"`` or ``"svg"``, from the suffix, else from the content."""
    suffix = path.suffix.lower()
    if suffix == ".path":
        return "path"
    if suffix in _SVG_SUFFIXES:
        return "svg"
    head = data[:4096].lstrip(b"\xef\xbb\xbf \t\r\n")
    if head.startswith(b"<"):
        return "svg"
    first = head.split(b"\n", 1)[0].strip()
    if re.fullmatch(rb"[0-9]+", first):
        return "path"
    raise InputError(
        path,
        "is neither an SVG nor a RepulsionPak .path file; give an .svg or .path file",
    )


def check_coordinates(path, values, what: str = "") -> None:
    """InputError naming ``path`` if ``values`` hold NaN/inf or |v| > :data:`MAX_COORD`."""
    a = np.asarray(values, dtype=float)
    if a.size == 0:
        return
    if not np.all(np.isfinite(a)):
        raise InputError(
            path,
            f"has non-finite coordinates (NaN or infinity){what}; check the path data and transforms",
        )
    big = float(np.abs(a).max())
    if big > MAX_COORD:
        raise InputError(
            path,
            f"has coordinates up to {big:.3g}{what}, beyond ±{MAX_COORD:.0e} user units; "
            "scale the drawing down (sizes are relative, any scale packs the same)",
        )


class TooManyPoints(InputError):
    """A file flattens to more than its point budget (:class:`PointBudget`)."""


class PointBudget:
    """Counts flattened vertices of one file; :class:`TooManyPoints` past ``limit``."""

    def __init__(self, path, limit: int | None = None):
        self.path, self.used = path, 0
        self.limit = MAX_POINTS if limit is None else limit

    def take(self, n: float) -> int:
        if not math.isfinite(n):
            raise InputError(self.path, "has non-finite coordinates (NaN or infinity)")
        self.used += n
        if self.used > self.limit:
            raise TooManyPoints(
                self.path,
                f"produces more than {self.limit} points after flattening curves; simplify the file or use a larger tolerance",
            )
        return int(n)


def _file_mode(path: Path) -> int:
    """The mode a new file would get (0666 & ~umask), or the mode of the file replaced."""
    try:
        return path.stat().st_mode & 0o777
    except OSError:
        umask = os.umask(0)
        os.umask(umask)
        return 0o666 & ~umask


def atomic_write_bytes(path: str | Path, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically: temp file in the same directory, fsync,
    ``os.replace``. OutputError if the directory is missing or not writable."""
    p = Path(path)
    parent = p.parent if str(p.parent) else Path(".")
    if not parent.is_dir():
        raise OutputError(
            f"{p}: the output directory {parent} does not exist; create it first"
        )
    if p.is_dir():
        raise OutputError(f"{p}: is a directory; give a file name for the output")
    tmp_name = None
    try:
        fd, tmp_name = tempfile.mkstemp(dir=parent, prefix=f".{p.name}.", suffix=".tmp")
        os.chmod(tmp_name, _file_mode(p))  # mkstemp makes 0600; outputs get the usual mode
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp_name, p)
        tmp_name = None
    except OSError as exc:
        raise OutputError(
            f"{p}: cannot write the output ({exc.strerror or exc}); check the directory permissions"
        ) from None
    finally:
        if tmp_name is not None:
            try:
                os.unlink(tmp_name)
            except OSError:
                pass
    try:  # make the rename durable; not possible everywhere (e.g. Windows)
        dfd = os.open(parent, os.O_RDONLY)
        try:
            os.fsync(dfd)
        finally:
            os.close(dfd)
    except OSError:
        pass
