"""``python -m repulsionpak.inkscape [--id=ID ...] [options] INPUT.svg > OUTPUT.svg``: the effect
on a file, as Inkscape runs it (the output document on stdout, errors as one line on stderr)."""

import sys


def _run() -> None:
    try:
        from .effect import main
    except ImportError as exc:  # inkex missing: one line, as Inkscape shows it
        sys.stderr.write(f"repulsionpak: the Inkscape extension needs inkex ({exc}); "
                         "install it with: pip install 'repulsionpak[inkscape]'\n")
        sys.exit(1)
    main()


if __name__ == "__main__":
    _run()
