"""``python -m repulsionpak.inkscape [--id=ID ...] [options] INPUT.svg > OUTPUT.svg``: the effect
on a file, as Inkscape runs it (the output document on stdout, errors as one line on stderr)."""

import os
import sys

#: Inkscape's own PYTHONPATH, set aside by the installed entry point
INKSCAPE_PATH = "REPULSIONPAK_INKSCAPE_PATH"


def _inkex_from_inkscape() -> None:
    """Where this environment has no ``inkex``, use the one Inkscape runs its extensions
    with (its folders from :data:`INKSCAPE_PATH`, after this environment's: inkex from
    PyPI needs PyGObject, which builds from source on Linux and macOS)."""
    import importlib.util

    if importlib.util.find_spec("inkex") is None:
        sys.path.extend(p for p in os.environ.get(INKSCAPE_PATH, "").split(os.pathsep) if p)


def _run() -> None:
    _inkex_from_inkscape()
    try:
        from .effect import main
    except ImportError as exc:  # inkex missing: one line, as Inkscape shows it
        sys.stderr.write(f"repulsionpak: the Inkscape extension needs inkex ({exc}); "
                         "install it with: pip install 'repulsionpak[inkscape]'\n")
        sys.exit(1)
    main()


if __name__ == "__main__":
    _run()
