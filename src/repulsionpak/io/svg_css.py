"""The CSS cascade of an SVG file's ``<style>`` sheets, resolved into ``style`` attributes.

Owns :func:`apply_stylesheets`: selectors matched by cssselect2, declarations ordered as
CSS orders them (``!important``, the element's own ``style``, the sheets by specificity and
order, above presentation attributes), and CSS custom properties (``var(--name,
fallback)``) substituted with the value each element inherits.

Notes
-----
svgelements, which reads the result, knows only single class, id and type selectors and
takes ``!important`` as part of a value; resolving the cascade here draws what browsers draw.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET

from .svg_xml import inline_declarations as _inline_declarations
from .svg_xml import local_name as _local

__all__ = ["apply_stylesheets"]


def apply_stylesheets(root: ET.Element, notes: set[str]) -> None:
    """Resolve the CSS cascade of the file's ``<style>`` sheets into each element's
    ``style`` attribute, and drop the sheets.

    Selectors are matched by cssselect2 (type, class, id, attribute, compound,
    descendant, child, sibling and structural selectors, as browsers match them);
    declarations are ordered as CSS orders them: ``!important`` ones first, then the
    element's own ``style``, then the sheets' by specificity and order, all above the
    presentation attributes (``fill="red"``). svgelements, which reads the result, only
    knows single class, id and type selectors and took ``!important`` as part of the value
    (a fill ``#abc !important`` came out black). At-rules (``@media``, ``@import``,
    ``@font-face``) are ignored."""
    sheets = [el for el in root.iter() if _local(el.tag) == "style"]
    inline_marked = [el for el in root.iter() if "!" in (el.get("style") or "")]
    custom = any("var(" in (el.get("style") or "") for el in root.iter()) or any(
        "var(" in "".join(sh.itertext()) for sh in sheets)
    if not sheets and not inline_marked and not custom:
        return
    matcher = None
    if sheets:
        import cssselect2  # noqa: PLC0415  (only files with style sheets need it)
        import tinycss2

        matcher = cssselect2.Matcher()
        for sheet in sheets:
            kind = (sheet.get("type") or "text/css").strip().lower()
            if kind not in ("text/css", ""):
                continue
            for rule in tinycss2.parse_stylesheet("".join(sheet.itertext()), skip_comments=True,
                                                  skip_whitespace=True):
                if rule.type != "qualified-rule":
                    continue
                decls = [(d.lower_name, tinycss2.serialize(d.value).strip(), bool(d.important))
                         for d in tinycss2.parse_declaration_list(rule.content, skip_comments=True,
                                                                  skip_whitespace=True)
                         if d.type == "declaration"]
                try:
                    selectors = cssselect2.compile_selector_list(rule.prelude)
                except cssselect2.SelectorError:
                    notes.add("CSS rule with a selector not understood")
                    continue
                for sel in selectors:
                    if sel.pseudo_element is None:
                        matcher.add_selector(sel, decls)
        parent = {c: p for p in root.iter() for c in p}
        for sheet in sheets:
            if sheet in parent:
                parent[sheet].remove(sheet)
    todo = {id(el): el for el in inline_marked}
    matched: dict[int, list] = {}
    if matcher is not None:
        for w in cssselect2.ElementWrapper.from_xml_root(root).iter_subtree():
            found = matcher.match(w)
            if found:
                matched[id(w.etree_element)] = found
                todo[id(w.etree_element)] = w.etree_element
    for key, el in todo.items():
        normal: dict[str, str] = {}
        important: dict[str, str] = {}
        for _spec, _order, _pseudo, decls in matched.get(key, ()):  # lowest to highest
            for name, value, imp in decls:
                (important if imp else normal)[name] = value
        own = _inline_declarations(el.get("style"))
        final = dict(normal)
        final.update({n: v for n, v, imp in own if not imp})
        final.update(important)
        final.update({n: v for n, v, imp in own if imp})
        if final:
            el.set("style", ";".join(f"{n}:{v}" for n, v in final.items()))
    if custom:
        _substitute_variables(root, notes)


_VAR = re.compile(r"var\(\s*(--[\w-]+)\s*(?:,((?:[^()]|\([^()]*\))*))?\)")


def _substitute_variables(root: ET.Element, notes: set[str]) -> None:
    """CSS custom properties: each element's ``style`` (the cascade resolved) with every
    ``var(--name, fallback)`` replaced by the value the element inherits or sets for
    ``--name`` (else the fallback). A declaration whose variable is defined nowhere is
    dropped with a note (svgelements took the text for a colour: black)."""

    def substitute(value: str, env: dict) -> str | None:
        for _ in range(32):  # nested var() and variables defined by others; a cycle gives up
            m = _VAR.search(value)
            if m is None:
                return value
            rep = env.get(m[1].lower())
            if rep is None:
                if m[2] is None:
                    return None
                rep = m[2].strip()
            value = value[:m.start()] + rep + value[m.end():]
        return None

    stack = [(root, {})]
    while stack:
        el, env = stack.pop()
        decls = _inline_declarations(el.get("style"))
        if any(n.startswith("--") for n, _, _ in decls):
            env = dict(env)
            for n, v, _ in decls:
                if n.startswith("--"):
                    r = substitute(v, env)
                    if r is None:
                        env.pop(n, None)
                    else:
                        env[n] = r
        if any(n.startswith("--") or "var(" in v for n, v, _ in decls):
            kept = []
            for n, v, imp in decls:
                if n.startswith("--"):
                    continue
                if "var(" in v:
                    r = substitute(v, env)
                    if r is None:
                        notes.add(f"CSS {n}: {v} with an undefined variable (ignored)")
                        continue
                    v = r
                kept.append(f"{n}:{v}" + (" !important" if imp else ""))
            el.set("style", ";".join(kept))
        stack.extend((c, env) for c in el if isinstance(c.tag, str))
