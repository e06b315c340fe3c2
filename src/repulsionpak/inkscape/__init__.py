"""The Inkscape extension: Extensions → Arrange → Pack into shape….

``repulsionpak inkscape-install`` puts ``repulsionpak_pack.inx`` and its entry point into the
user's Inkscape extensions folder (:mod:`repulsionpak.inkscape.install`); the effect itself
(:class:`~repulsionpak.inkscape.effect.PackIntoShape`) also runs from the command line as
inkex's extensions do::

    python -m repulsionpak.inkscape --id=CONTAINER --id=ELEMENT ... [--gap G] [--seed N] IN.svg > OUT.svg

It needs ``inkex`` (``pip install 'repulsionpak[inkscape]'``); importing this package does not.
"""

INX_NAME = "repulsionpak_pack.inx"
ENTRY_NAME = "repulsionpak_pack.py"

__all__ = ["INX_NAME", "ENTRY_NAME"]
