"""The final verification of a packing's promises on the art itself, and its repair.

The simulation works on meshes and skins; what a user gets is the art mapped through
them. :func:`verify_and_repair` checks the promises (no overlap, inside the container a
margin from its edge, a gap floor between elements) on the exact art polygons and
repairs what breaks them; :func:`straighten` replaces copies bent too far by their
unbent copy first.

* :mod:`.checks` – measuring what holds (:class:`Verification`, the per-element needs).
* :mod:`.repairs` – the repairs: move, shrink, drop, grow, gather, straighten.
* :mod:`.dents` – the repair by local bending, before any move or shrink.
"""

from .checks import Verification
from .dents import dent
from .repairs import scaled_art, similar_copy, straighten, verify_and_repair

__all__ = ["Verification", "dent", "scaled_art", "similar_copy", "straighten", "verify_and_repair"]
