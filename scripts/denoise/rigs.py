"""The light rigs the denoiser is measured under (TOML, docs/reference/lights.md): the viewer's default
sun and sky, a low sun whose shadows cross the floor, and a sky alone."""

RIGS = {
    "sun-and-sky": """
[[light]]
kind = "sun"
theta = 65
phi = 30
color = [1.0, 0.92, 0.8]
intensity = 3.0

[[light]]
kind = "hemisphere"
color = [0.15, 0.19, 0.27]
ground_color = [0.05, 0.045, 0.04]
""",
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
