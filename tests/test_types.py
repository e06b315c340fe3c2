"""The art types' helpers: several paths moved under one map."""

from __future__ import annotations

import numpy as np
import pytest

from repulsionpak import examples
from repulsionpak.io import load_element
from repulsionpak.types import transformed_paths


def _same(a, b) -> bool:
    """Whether two paths hold the same points and (where they have them) curves, to the bit."""
    if len(a.subpaths) != len(b.subpaths) or any(not np.array_equal(p, q) for p, q in zip(a.subpaths, b.subpaths)):
        return False
    if (a.source is None) != (b.source is None):
        return False
    if a.source is None:
        return True
    return (np.array_equal(a.source.matrix, b.source.matrix)
            and all(np.array_equal(c.ctrl, d.ctrl) and np.array_equal(c.order, d.order)
                    for c, d in zip(a.source.curves, b.source.curves, strict=True)))


@pytest.mark.parametrize("kind", ["affine", "bent"])
def test_transformed_paths_moves_each_path_as_transformed_does(kind):
    """One probe of the map for all of a copy's paths gives each path, to the bit, what its
    own ``transformed`` gives: the curves move with an affine map and are dropped under a
    map that is not."""
    paths = load_element(examples.element_files()[0]).paths
    assert len(paths) >= 2 and all(a.source is not None for a in paths)
    c, s = np.array([3.0, -2.0]), 0.37
    if kind == "affine":
        def fn(p):
            return (np.asarray(p) - c) * s + [10.0, 20.0]
    else:
        def fn(p):
            p = np.asarray(p)
            return p + 0.01 * p[:, ::-1] ** 2

    together = transformed_paths(paths, fn)
    alone = tuple(a.transformed(fn) for a in paths)
    assert all(_same(a, b) for a, b in zip(together, alone, strict=True))
    assert all((a.source is not None) == (kind == "affine") for a in together)
    assert not np.array_equal(together[0].subpaths[0], paths[0].subpaths[0])
