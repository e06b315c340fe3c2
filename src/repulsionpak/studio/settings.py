"""The studio's settings: the ``repulsionpak pack`` options a designer tunes in the page.

Defaults, ranges and error messages come from the library (:class:`repulsionpak.params.Params`
and its ``validate``, :func:`repulsionpak.controls.cli_controls` for the element controls), so
the page refuses exactly what the command line refuses, with the same words. The page's
values arrive as strings or JSON scalars; :func:`coerce` types them, :func:`run_settings`
turns the whole set into the run's parameters and element controls, and :func:`command_line`
into the equivalent command.
"""

from __future__ import annotations

import dataclasses
import json
import math
import shlex
from collections.abc import Sequence

from ..controls import cli_controls
from ..types import ElementControls
from ..errors import ParameterError
from ..params import MAX_COUNT, Params

_P = Params()
_C = ElementControls()

#: the settings and their defaults (the CLI's: None = chosen by the run)
DEFAULTS: dict[str, object] = {
    "gap": _P.gap,                      # None: 1% of the container's size (library policy)
    "count": _P.placement.count,        # None: from the container's area and the gap
    "seed": _P.seed,                    # None: drawn at random when a run starts
    "rotation": _C.rotation,            # free | fixed[:ANGLE] | limited:DEG | upright[:DEG]
    "rigid": _C.rigid,
    "stiffness": _C.stiffness,
    "pocket_fill": _P.secondary.auto,
}

#: what the page shows beside each setting (kind, range, the CLI option)
SPEC: dict[str, dict] = {
    "gap": {"kind": "number", "min_exclusive": 0, "option": "--gap", "empty": "auto"},
    "count": {"kind": "integer", "min": 1, "max": MAX_COUNT, "option": "--count", "empty": "auto"},
    "seed": {"kind": "integer", "min": 0, "max": 2**64 - 1, "option": "--seed", "empty": "random"},
    "rotation": {"kind": "rotation", "choices": ["free", "fixed", "limited", "upright"], "option": "--rotation"},
    "rigid": {"kind": "boolean", "option": "--rigid"},
    "stiffness": {"kind": "number", "min_exclusive": 0, "option": "--stiffness"},
    "pocket_fill": {"kind": "boolean", "option": "--no-pocket-fill"},
}


def coerce(name: str, value: object) -> object:
    """The page's ``value`` of setting ``name`` typed (an empty string: the default);
    raises :class:`ParameterError` naming the option when it is not of the right kind."""
    if name not in DEFAULTS:
        raise ParameterError(f"unknown setting {name!r}; the settings are {', '.join(DEFAULTS)}")
    kind = SPEC[name]["kind"]
    option = SPEC[name]["option"]
    if value is None or (isinstance(value, str) and not value.strip()):
        return DEFAULTS[name]
    if kind == "boolean":
        if isinstance(value, bool):
            return value
        if isinstance(value, str) and value.lower() in ("true", "false", "on", "off"):
            return value.lower() in ("true", "on")
        raise ParameterError(f"{option}: expected true or false, got {value!r}")
    if kind == "rotation":
        if not isinstance(value, str):
            raise ParameterError(f"{option} must be free, fixed[:ANGLE] or limited:DEG, got {value!r}")
        return value.strip()
    if isinstance(value, bool):
        raise ParameterError(f"{option} must be a number, got {value!r}")
    if kind == "integer":
        if isinstance(value, int):
            return value
        if isinstance(value, float) and value.is_integer():
            return int(value)
        try:
            return int(str(value).strip())
        except ValueError:
            raise ParameterError(f"{option} must be a whole number, got {value!r}") from None
    try:
        f = float(value)
    except (TypeError, ValueError):
        raise ParameterError(f"{option} must be a number, got {value!r}") from None
    if not math.isfinite(f):
        raise ParameterError(f"{option} must be a finite number, got {value!r}")
    return f


def run_settings(settings: dict) -> tuple[Params, ElementControls | None]:
    """The parameters and element controls of ``repulsionpak pack`` with these options.

    Parameters
    ----------
    settings : dict
        Keys of :data:`DEFAULTS` (missing ones take their default).

    Returns
    -------
    params : Params
        Validated; ``gap`` and ``seed`` stay None when not set.
    controls : ElementControls or None
        The ``--rotation``/``--rigid``/``--stiffness`` defaults of every element (None: none given).

    Raises
    ------
    ParameterError
        With the library's message, prefixed by the option it concerns.
    """
    s = dict(DEFAULTS, **settings)
    p = Params()
    try:
        if s["gap"] is not None:
            p = dataclasses.replace(p, gap=s["gap"])
        if s["seed"] is not None:
            p = dataclasses.replace(p, seed=s["seed"])
        if s["count"] is not None:
            p = dataclasses.replace(p, placement=dataclasses.replace(p.placement, count=s["count"]))
        if not s["pocket_fill"]:  # as --no-pocket-fill: no copies in the pockets, none in holes
            p = p.without_pocket_fill()
        p = p.validate()
    except ParameterError as exc:
        option = next((SPEC[k]["option"] for k in ("gap", "seed", "count") if k in str(exc).split(" ")[0]), None)
        raise ParameterError(f"{option}: {exc}" if option else str(exc)) from None
    controls = cli_controls(*_control_options(s))
    return p, controls


def _control_options(s: dict) -> tuple[str | None, bool, float | None]:
    rotation = None if s["rotation"] == DEFAULTS["rotation"] else s["rotation"]
    stiffness = None if s["stiffness"] == DEFAULTS["stiffness"] else s["stiffness"]
    return rotation, bool(s["rigid"]), stiffness


#: an element's own settings in the page (None: the run's setting applies)
ELEMENT_KEYS = ("rotation", "rigid", "stiffness", "axis", "flow", "flow_bend")


def coerce_element(key: str, value: object) -> object:
    """The page's ``value`` of element setting ``key`` typed and checked as the element
    manifest checks it (empty or None: the run's setting applies, None); raises
    :class:`ParameterError` with the manifest's words."""
    if key not in ELEMENT_KEYS:
        raise ParameterError(f"unknown element setting {key!r}; they are {', '.join(ELEMENT_KEYS)}")
    if value is None or (isinstance(value, str) and value.strip().lower() in ("", "default")):
        return None
    if key == "rotation":
        v = coerce("rotation", value)
    elif key in ("rigid", "flow_bend"):
        v = coerce("rigid", value)
    elif key == "flow":
        v = str(value).strip().lower()
    else:
        try:
            v = float(value)
        except (TypeError, ValueError):
            raise ParameterError(f"{key} must be a number, got {value!r}") from None
    manifest_keys({key: v})  # its check (ElementControls) and message
    return v


def manifest_keys(overrides: dict) -> dict:
    """The element manifest's keys (``rotation``, ``angle``, ``max_rotation``, ``rigid``,
    ``stiffness``, ``axis``, ``flow``, ``flow_bend``) of an element's own settings (``rotation`` as ``--rotation`` gives
    it: ``fixed:30``, ``limited:15``, ``upright:10``), checked by :class:`ElementControls`."""
    from ..controls import parse_rotation

    out: dict = {}
    for key, v in overrides.items():
        if v is None:
            continue
        if key == "rotation":
            name, value = parse_rotation(str(v))
            out["rotation"] = name
            if value is not None:
                out["angle" if name == "fixed" else "max_rotation"] = value
        elif key == "rigid":
            out["rigid"] = bool(v)
        elif key in ("stiffness", "axis"):
            out[key] = float(v)
        elif key == "flow":
            out["flow"] = str(v)
        elif key == "flow_bend":
            out["flow_bend"] = bool(v)
    try:
        ElementControls(**out)
    except ParameterError as exc:
        raise ParameterError(f"element setting: {exc}") from None
    return out


def element_manifest(files: Sequence[tuple]) -> str:
    """An element manifest (``.toml``, see docs/controls.md) naming ``files``: (path as the
    manifest should give it, weight[, the element's own settings as in
    :func:`manifest_keys`])."""
    lines = ["# the studio's elements and their settings (repulsionpak pack reads it as an element argument)"]
    for name, weight, *rest in files:
        lines += ["", "[[element]]", f"file = {json.dumps(str(name))}"]
        if weight != 1.0:
            lines.append(f"weight = {_num(weight)}")
        for k, v in manifest_keys(dict(rest[0]) if rest else {}).items():
            lines.append(f"{k} = " + (json.dumps(v) if isinstance(v, (str, bool)) else _num(v)))
    return "\n".join(lines) + "\n"


def _num(v: float) -> str:
    return f"{v:g}" if float(v) == float(f"{v:g}") else repr(float(v))


def command_line(settings: dict, container: str, elements: Sequence[str], output: str = "packing.svg",
                 secondary: Sequence[str] = (), flow: str | None = None) -> str:
    """The ``repulsionpak pack`` command with these settings (paths as given, quoted for a
    shell; ``flow``: the guide file, ``--flow``)."""
    s = dict(DEFAULTS, **settings)
    args = ["repulsionpak", "pack", container, *elements, "-o", output]
    for f in secondary:
        args += ["--secondary", f]
    if flow is not None:
        args += ["--flow", flow]
    if s["gap"] is not None:
        args += ["--gap", _num(s["gap"])]
    if s["seed"] is not None:
        args += ["--seed", str(s["seed"])]
    if s["count"] is not None:
        args += ["--count", str(s["count"])]
    rotation, rigid, stiffness = _control_options(s)
    if rotation is not None:
        args += ["--rotation", rotation]
    if rigid:
        args.append("--rigid")
    if stiffness is not None:
        args += ["--stiffness", _num(stiffness)]
    if not s["pocket_fill"]:
        args.append("--no-pocket-fill")
    return shlex.join(args)


__all__ = ["DEFAULTS", "ELEMENT_KEYS", "SPEC", "coerce", "coerce_element", "command_line", "element_manifest",
           "manifest_keys", "run_settings"]
