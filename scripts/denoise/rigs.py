"""The light rigs the denoiser is measured under (TOML, docs/reference/lights.md): the viewer's default
sun and sky, a low sun whose shadows cross the floor, and a sky alone."""

import os

# The viewer's own default lights.
with open(os.path.join(os.path.dirname(__file__), "..", "..", "viewer", "src", "default-rig.toml")) as f:
    DEFAULT_RIG = f.read()

RIGS = {
    "sun-and-sky": DEFAULT_RIG,
    "low-sun": """
[[light]]
kind = "sun"
theta = 78
phi = 200
color = [1.0, 0.8, 0.6]
intensity = 4.0
""",
    "sky": """
[[light]]
kind = "hemisphere"
color = [0.4, 0.5, 0.7]
ground_color = [0.1, 0.09, 0.08]
""",
}
