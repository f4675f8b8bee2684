"""The add-on's one error type: what the operators report in Blender's UI."""


class PrtError(Exception):
    """A problem to tell the user (no prt-bake, a failed bake, nothing to bake, …)."""
