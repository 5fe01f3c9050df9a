"""Which OpenGL MuJoCo uses (``MUJOCO_GL``), chosen before MuJoCo is first imported.

MuJoCo reads ``MUJOCO_GL`` when it is imported and, set to ``egl`` on a machine without libEGL, fails to
import at all, though a trial draws nothing. :func:`default_gl` sets it where the user has not: ``egl``
(headless rendering) where libEGL can be loaded, else ``disable`` (MuJoCo without OpenGL: trials and sweeps
run; rendering says what it needs, :func:`require_gl`).
"""

from __future__ import annotations

import ctypes.util
import os

NO_GL = ("disable", "disabled", "off", "false", "0")
"""``MUJOCO_GL`` values with which MuJoCo imports without OpenGL (its own list)."""


def default_gl() -> str:
    """``MUJOCO_GL``, set first where it is not: ``egl`` if libEGL loads, else ``disable``."""
    if not os.environ.get("MUJOCO_GL"):
        os.environ["MUJOCO_GL"] = "egl" if ctypes.util.find_library("EGL") else "disable"
    return os.environ["MUJOCO_GL"]


class NoGLError(RuntimeError):
    """Rendering asked for where MuJoCo has no OpenGL."""


def require_gl(what: str = "rendering") -> None:
    """Raise :class:`NoGLError` (one line: what is missing and what to set) where ``MUJOCO_GL`` disables
    OpenGL."""
    value = os.environ.get("MUJOCO_GL", "").lower().strip()
    if value in NO_GL:
        raise NoGLError(
            f"{what} needs OpenGL, but MUJOCO_GL={value} (no libEGL found, or set so): install libEGL "
            "(Debian: libegl1) or set MUJOCO_GL=egl, osmesa or glfw"
        )
