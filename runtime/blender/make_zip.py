"""Packs the add-on into a zip that Blender installs (Edit > Preferences > Get Extensions >
Install from Disk, or Add-ons > Install from Disk on a legacy setup).

    python3 runtime/blender/make_zip.py OUT.zip

The zip holds one folder, prt_bake/, with blender_manifest.toml (a Blender 4.2+ extension)
and bl_info in __init__.py (a legacy add-on): Blender accepts either from the same zip.
Entries are written in name order with a fixed time stamp, so the zip is reproducible.
"""

import sys
import zipfile
from pathlib import Path

SOURCE = Path(__file__).resolve().parent / "prt_bake"


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: make_zip.py OUT.zip")
    out = Path(sys.argv[1])
    files = sorted(p for p in SOURCE.rglob("*")
                   if p.is_file() and "__pycache__" not in p.parts)
    with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as z:
        for path in files:
            info = zipfile.ZipInfo(f"prt_bake/{path.relative_to(SOURCE).as_posix()}",
                                   date_time=(2024, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = 0o644 << 16
            z.writestr(info, path.read_bytes())
    print(f"{out}: {len(files)} files")


main()
