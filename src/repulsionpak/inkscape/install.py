"""``repulsionpak inkscape-install``: the extension into the user's Inkscape extensions folder.

Inkscape runs an extension's script with its own Python, with its own ``inkex`` first on
``PYTHONPATH``; repulsionpak and its compiled dependencies live in another environment.
The installed entry point therefore carries the interpreter and the import path this
command ran with, and hands the effect over to them: Inkscape's Python only starts it.
Inkscape's path is handed over aside (``REPULSIONPAK_INKSCAPE_PATH``): the effect uses the
environment's ``inkex`` when it has one (``repulsionpak[inkscape]``) and Inkscape's otherwise.
"""

from __future__ import annotations

import os
import sys
from importlib import resources
from pathlib import Path

from . import ENTRY_NAME, INX_NAME

ENTRY_TEMPLATE = '''#!/usr/bin/env python3
"""Inkscape entry point of repulsionpak's Extensions > Arrange > Pack into shape.

Written by `repulsionpak inkscape-install`: Inkscape starts this file with its own Python;
it runs the effect with the Python repulsionpak is installed in (run the command again
after moving or rebuilding that environment).
"""
import os
import subprocess
import sys

PYTHON = {python!r}
IMPORT_PATH = {import_path!r}


def main():
    if not os.path.exists(PYTHON):
        sys.stderr.write("repulsionpak: the Python this extension was installed with (" + PYTHON + ") is "
                         "gone; run `repulsionpak inkscape-install` again from its new environment\\n")
        return 1
    env = dict(os.environ)
    # not Inkscape's path (its folders would shadow this environment's packages); kept aside
    # so that its inkex serves where this environment has none (python -m repulsionpak.inkscape)
    env["REPULSIONPAK_INKSCAPE_PATH"] = env.get("PYTHONPATH", "")
    env["PYTHONPATH"] = IMPORT_PATH
    env.pop("PYTHONHOME", None)
    argv = [PYTHON, "-m", "repulsionpak.inkscape", *sys.argv[1:]]
    if os.name == "posix":  # this process becomes the effect: Inkscape's Cancel ends it
        os.execve(PYTHON, argv, env)
    return subprocess.call(argv, env=env)


if __name__ == "__main__":
    sys.exit(main())
'''


def default_dir(platform: str | None = None, env: dict | None = None, home: Path | None = None) -> Path:
    """The user's Inkscape extensions folder.

    Parameters
    ----------
    platform : str, optional
        ``sys.platform`` by default.
    env : dict, optional
        The environment (``os.environ`` by default): ``APPDATA`` on Windows,
        ``XDG_CONFIG_HOME`` elsewhere.
    home : Path, optional
        The home folder (``Path.home()`` by default).

    Returns
    -------
    Path
        ``%APPDATA%\\inkscape\\extensions`` (Windows),
        ``~/Library/Application Support/org.inkscape.Inkscape/config/inkscape/extensions``
        (macOS), ``$XDG_CONFIG_HOME/inkscape/extensions`` or ``~/.config/inkscape/extensions``.
    """
    platform = sys.platform if platform is None else platform
    env = os.environ if env is None else env
    home = Path.home() if home is None else Path(home)
    if platform.startswith("win"):
        base = env.get("APPDATA")
        return (Path(base) if base else home / "AppData" / "Roaming") / "inkscape" / "extensions"
    if platform == "darwin":
        return home / "Library" / "Application Support" / "org.inkscape.Inkscape" / "config" / "inkscape" / "extensions"
    xdg = env.get("XDG_CONFIG_HOME")
    return (Path(xdg) if xdg else home / ".config") / "inkscape" / "extensions"


def entry_script(python: str | None = None, import_path: str | None = None) -> str:
    """The entry point's text, pinned to ``python`` (default ``sys.executable``) and the
    folder repulsionpak is imported from (default: this installation's)."""
    if import_path is None:
        import repulsionpak  # noqa: PLC0415

        import_path = str(Path(repulsionpak.__file__).resolve().parent.parent)
    return ENTRY_TEMPLATE.format(python=python or sys.executable, import_path=import_path)


def inx_text() -> str:
    """The shipped ``repulsionpak_pack.inx``."""
    return resources.files(__package__).joinpath(INX_NAME).read_text(encoding="utf-8")


def targets(folder: Path | None = None) -> tuple[Path, Path]:
    """(the .inx path, the entry point's path) in ``folder`` (default: :func:`default_dir`)."""
    d = Path(folder) if folder is not None else default_dir()
    return d / INX_NAME, d / ENTRY_NAME


def install(folder: Path | None = None, dry_run: bool = False) -> tuple[Path, Path]:
    """Write the .inx and the entry point into ``folder`` (created if missing).

    Parameters
    ----------
    folder : Path, optional
        Default: the user's Inkscape extensions folder (:func:`default_dir`).
    dry_run : bool
        Only return where they would go.

    Returns
    -------
    (Path, Path)
        The .inx file and the entry point.

    Raises
    ------
    repulsionpak.OutputError
        The folder cannot be created or written.
    """
    from repulsionpak import OutputError  # noqa: PLC0415

    inx, entry = targets(folder)
    if dry_run:
        return inx, entry
    try:
        inx.parent.mkdir(parents=True, exist_ok=True)
        inx.write_text(inx_text(), encoding="utf-8")
        entry.write_text(entry_script(), encoding="utf-8")
        entry.chmod(0o755)
    except OSError as exc:
        raise OutputError(f"{inx.parent}: cannot install the Inkscape extension here "
                          f"({exc.strerror or exc})") from None
    return inx, entry


__all__ = ["default_dir", "entry_script", "install", "inx_text", "targets"]
