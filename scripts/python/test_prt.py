"""Tests prt.py against `prt-bake export --npz` and `prt-bake inspect` on every variant:
grey and RGB transfer, orders 1, 3, 4 and 5, with and without the aux arrays, z- and y-up;
and that corrupted or truncated files are refused. Usage: test_prt.py PRT_BAKE OUT_DIR."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from prt import PrtError, parse_prt, read_prt  # noqa: E402

bake_bin, out = sys.argv[1], Path(sys.argv[2])
out.mkdir(parents=True, exist_ok=True)
root = Path(__file__).resolve().parents[2]
cornell = str(root / "scenes/cornell/cornell.scene")
torus = str(root / "scenes/torus/torus.scene")

VARIANTS = {
    "grey-order3-aux": (torus, ["--order", "3", "--aux", "ao,bent-normal"]),
    "rgb-order5-ao": (cornell, ["--order", "5", "--mode", "interreflected", "--aux", "ao"]),
    "grey-order1-unshadowed": (cornell, ["--order", "1", "--mode", "unshadowed"]),
    "grey-order4-y-up": (cornell, ["--up", "y"]),
}


def run(*args):
    return subprocess.run([bake_bin, *args], check=True, capture_output=True, text=True).stdout


for name, (scene, extra) in VARIANTS.items():
    prt, npz = out / f"{name}.prt", out / f"{name}.npz"
    run("bake", scene, "-o", str(prt), "--samples", "32", "--quiet", *extra)
    run("export", str(prt), "--scene", scene, "--npz", str(npz))
    f, arrays = read_prt(prt), np.load(npz)
    inspected = json.loads(run("inspect", str(prt)))
    assert all(inspected[key] == value for key, value in f.header.items()), (name, f.header, inspected)
    assert np.array_equal(f.transfer, arrays["transfer"]), name
    for aux in ("ao", "bent_normal"):
        ours = getattr(f, aux)
        assert (ours is None) == (aux not in arrays), (name, aux)
        if ours is not None:
            assert np.array_equal(ours, arrays[aux]), (name, aux)
    assert arrays["triangles"].dtype == np.uint32 and arrays["triangles"].max() < f.header["vertex_count"]
    print(f"test_prt.py: {name}: transfer {f.transfer.shape}, aux {f.header['aux']}, up {f.header['up']}: "
          "equal to the npz export")

data = (out / "grey-order3-aux.prt").read_bytes()
for broken, reason in ((data[:-4], "announces"), (data[:200] + b"\0" + data[201:], "checksum"),
                       (b"not a prt" + data[9:], "magic")):
    try:
        parse_prt(broken)
    except PrtError as err:
        assert reason in str(err), err
    else:
        raise AssertionError(f"a file with a bad {reason} was read")
print("test_prt.py: truncated, corrupted and foreign files are refused")
