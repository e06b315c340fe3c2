"""Make docs/images/inkscape-result.png and docs/images/inkscape-dialog.png: the Inkscape
extension run by the real ``inkscape`` on an A4 document drawn from the shipped examples, and
its dialog.

    python docs/make_inkscape_pictures.py [--out-dir docs/images] [--keep DIR]

Needs ``inkscape`` and ``xvfb-run`` (Debian: ``apt-get install inkscape xvfb``) and, for the
dialog, ImageMagick's ``import``. The extension is installed into a temporary HOME.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

from lxml import etree

from repulsionpak import examples
from repulsionpak.inkscape.install import install

SVG = "http://www.w3.org/2000/svg"
#: the dialog's settings, as Inkscape keeps them in preferences.xml
SETTINGS = {"gap": "2.5", "count": "12", "seed": "1", "pocket_fill": "true", "container_paint": "none"}
ELEMENTS = ("apple", "fish", "leaf", "bird")


def demo_document() -> bytes:
    """An A4 landscape mm document as Inkscape writes one: a layer with a transform holding
    the example heart (scaled by its own transform) and four example elements beside it."""
    ex = Path(examples.__file__).parent
    heart = etree.parse(str(ex / "containers" / "heart.svg")).getroot().find(f"{{{SVG}}}path")
    parts = []
    for k, name in enumerate(ELEMENTS):
        root = etree.parse(str(ex / "elements" / f"{name}.svg")).getroot()
        inner = "".join(etree.tostring(c).decode() for c in root
                        if isinstance(c.tag, str) and etree.QName(c).localname not in ("title", "desc"))
        parts.append(f'<g id="{name}" transform="translate(12,{12 + 48 * k}) scale(0.25)">{inner}</g>')
    return f'''<?xml version="1.0" encoding="UTF-8" standalone="no"?>
<svg width="297mm" height="210mm" viewBox="0 0 297 210" version="1.1" id="svg1"
   xmlns:inkscape="http://www.inkscape.org/namespaces/inkscape"
   xmlns:sodipodi="http://sodipodi.sourceforge.net/DTD/sodipodi-0.dtd"
   xmlns="http://www.w3.org/2000/svg" xmlns:svg="http://www.w3.org/2000/svg">
  <sodipodi:namedview id="namedview1" inkscape:document-units="mm" inkscape:current-layer="layer1" />
  <defs id="defs1" />
  <g inkscape:label="Artwork" inkscape:groupmode="layer" id="layer1" transform="translate(4,0)">
    {"".join(parts)}
    <path id="heart" style="fill:none;stroke:#000000;stroke-width:1.2"
       transform="matrix(0.4,0,0,0.4,88,6)" d="{heart.get('d')}" />
  </g>
</svg>
'''.encode()


def preferences(extra: str = "") -> str:
    attrs = " ".join(f'org.repulsionpak.pack.{k}="{v}"' for k, v in SETTINGS.items())
    return (f'<?xml version="1.0" encoding="UTF-8" standalone="no"?>\n<inkscape version="1">\n'
            f'  <group id="extensions" {attrs} />\n{extra}</inkscape>\n')


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out-dir", type=Path, default=Path(__file__).parent / "images")
    ap.add_argument("--keep", type=Path, help="also keep the input and output documents here")
    args = ap.parse_args()
    for tool in ("inkscape", "xvfb-run"):
        if not shutil.which(tool):
            raise SystemExit(f"{tool} not found: apt-get install inkscape xvfb")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        home = tmp / "home"
        install(home / ".config" / "inkscape" / "extensions")
        prefs = home / ".config" / "inkscape" / "preferences.xml"
        prefs.write_text(preferences())
        env = dict(os.environ, HOME=str(home))
        env.pop("XDG_CONFIG_HOME", None)
        src, out = tmp / "demo.svg", tmp / "demo-packed.svg"
        src.write_bytes(demo_document())
        ids = ",".join(["heart", *ELEMENTS])
        actions = f"select-by-id:{ids};org.repulsionpak.pack.noprefs;export-filename:{out};export-do"
        subprocess.run(["xvfb-run", "-a", "inkscape", "--batch-process", f"--actions={actions}", str(src)],
                       env=env, check=True, capture_output=True, timeout=1800)
        args.out_dir.mkdir(parents=True, exist_ok=True)
        png = args.out_dir / "inkscape-result.png"
        subprocess.run(["inkscape", "--export-type=png", "--export-dpi=110", "--export-background=#ffffff",
                        "--export-background-opacity=1", f"--export-filename={png}", str(out)],
                       env=env, check=True, capture_output=True, timeout=600)
        print(png)
        if args.keep:
            args.keep.mkdir(parents=True, exist_ok=True)
            shutil.copy(src, args.keep / src.name)
            shutil.copy(out, args.keep / out.name)
        if not shutil.which("import"):
            print("ImageMagick's import not found: no dialog screenshot")
            return
        # the dialog: the GUI with the main window beside it, the pointer away from both
        prefs.write_text(preferences('  <group id="desktop"><group id="geometry" x="560" y="0" width="800" '
                                     'height="600" maximized="0" fullscreen="0" /></group>\n'))
        dialog = args.out_dir / "inkscape-dialog.png"
        script = (f'inkscape --with-gui --actions="select-by-id:{ids};org.repulsionpak.pack" "{src}" '
                  f'>/dev/null 2>&1 & P=$!; sleep 30; '
                  f'G=$(xwininfo -root -tree | grep \'"Pack into shape"\' | grep -o "[0-9]*x[0-9]*+[0-9]*+[0-9]*" | head -1); '
                  f'import -window root -crop "$G" "{dialog}"; kill $P; wait $P 2>/dev/null; true')
        subprocess.run(["xvfb-run", "-a", "-s", "-screen 0 2400x1800x24", "bash", "-c", script],
                       env=env, check=True, capture_output=True, timeout=600)
        print(dialog)


if __name__ == "__main__":
    main()
