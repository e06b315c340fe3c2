"""``python -m repulsionpak.cli``: the ``repulsionpak`` command."""

from . import main

main()
