"""Finding and running the prt-bake binary; its failures become PrtError with its message."""

import os
import shutil
import subprocess

from .errors import PrtError


def find_prt_bake(configured):
    """The preferences' path if set, else `prt-bake` on PATH."""
    if configured:
        path = os.path.abspath(os.path.expanduser(configured))
        if not (os.path.isfile(path) and os.access(path, os.X_OK)):
            raise PrtError(f"prt-bake not found at {path} (the add-on's preferences)")
        return path
    found = shutil.which("prt-bake")
    if found is None:
        raise PrtError("prt-bake not found on PATH: install it, or set its path in the "
                       "add-on's preferences (Edit > Preferences > Add-ons > PRT Bake)")
    return found


def failure(command, returncode, stderr):
    """A PrtError naming the step and prt-bake's own last error line."""
    lines = [line for line in stderr.splitlines() if line.strip()]
    detail = next((line for line in reversed(lines) if "error" in line), lines[-1] if lines else "")
    return PrtError(f"prt-bake {command} failed (exit {returncode}): {detail}".rstrip(": "))


def run_prt_bake(executable, arguments):
    """Runs one short prt-bake command to its end."""
    try:
        done = subprocess.run([executable, *arguments], capture_output=True, text=True)
    except OSError as err:
        raise PrtError(f"cannot run {executable}: {err}") from None
    if done.returncode != 0:
        raise failure(arguments[0], done.returncode, done.stderr)
    return done
