"""Headless OpenGL for pyrender: choose EGL or OSMesa before pyrender is imported.

PyOpenGL reads ``PYOPENGL_PLATFORM`` once, when ``OpenGL`` is first imported, so the choice has
to be made before that and cannot be undone in the same process. The probes here load the system
libraries with ctypes (no OpenGL import) and mirror what pyrender's EGL platform does (first EGL
device, ``eglInitialize``), so a machine whose EGL loads but cannot initialise falls through to
OSMesa instead of failing inside pyrender.
"""

from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import os
import sys
from collections.abc import Iterator
from types import ModuleType
from typing import Any

from morphkit.errors import MorphkitError

__all__ = ["RenderUnavailableError", "import_pyrender", "offscreen_renderer", "select_platform"]

_INSTALL_HINT = (
    "install a headless OpenGL: `apt-get install libegl1 libgl1-mesa-dri` (EGL with Mesa's software "
    "rasteriser) or `apt-get install libosmesa6` (OSMesa)"
)
_EGL_PLATFORM_DEVICE_EXT = 0x313F


class RenderUnavailableError(MorphkitError):
    """Offscreen rendering cannot run here: pyrender or a headless OpenGL library is missing."""


def _has_display() -> bool:
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def _load(names: tuple[str, ...]) -> ctypes.CDLL | None:
    for name in names:
        found = ctypes.util.find_library(name) if "." not in name else name
        if not found:
            continue
        try:
            return ctypes.CDLL(found)
        except OSError:
            continue
    return None


def _egl_works() -> bool:
    """Whether libEGL loads and its first device (or default display) initialises."""
    lib = _load(("EGL", "libEGL.so.1"))
    if lib is None:
        return False
    try:
        lib.eglGetProcAddress.restype = ctypes.c_void_p
        lib.eglGetProcAddress.argtypes = [ctypes.c_char_p]
        lib.eglInitialize.argtypes = [ctypes.c_void_p, ctypes.POINTER(ctypes.c_int), ctypes.POINTER(ctypes.c_int)]
        lib.eglTerminate.argtypes = [ctypes.c_void_p]
        query = lib.eglGetProcAddress(b"eglQueryDevicesEXT")
        platform_display = lib.eglGetProcAddress(b"eglGetPlatformDisplayEXT")
        display: int | None = None
        if query and platform_display:
            # pyrender's EGL platform takes the first device when the extension exists: probe that one.
            query_fn = ctypes.CFUNCTYPE(
                ctypes.c_uint, ctypes.c_int, ctypes.POINTER(ctypes.c_void_p), ctypes.POINTER(ctypes.c_int)
            )(query)
            count = ctypes.c_int()
            if not query_fn(0, None, ctypes.byref(count)) or count.value < 1:
                return False
            devices = (ctypes.c_void_p * count.value)()
            if not query_fn(count.value, devices, ctypes.byref(count)):
                return False
            display_fn = ctypes.CFUNCTYPE(ctypes.c_void_p, ctypes.c_uint, ctypes.c_void_p, ctypes.c_void_p)(
                platform_display
            )
            display = display_fn(_EGL_PLATFORM_DEVICE_EXT, devices[0], None)
        else:
            lib.eglGetDisplay.restype = ctypes.c_void_p
            lib.eglGetDisplay.argtypes = [ctypes.c_void_p]
            display = lib.eglGetDisplay(None)
        if not display:
            return False
        major, minor = ctypes.c_int(), ctypes.c_int()
        ok = bool(lib.eglInitialize(display, ctypes.byref(major), ctypes.byref(minor)))
        if ok:
            lib.eglTerminate(display)
        return ok
    except (AttributeError, OSError):
        return False


def _osmesa_works() -> bool:
    lib = _load(("OSMesa", "libOSMesa.so.8", "libOSMesa.so.6"))
    return lib is not None and hasattr(lib, "OSMesaCreateContextExt")


def select_platform() -> str:
    """Choose PyOpenGL's platform for offscreen rendering and set ``PYOPENGL_PLATFORM``.

    A platform the user set is kept. Without a display (Linux servers, CI), EGL is tried first and
    OSMesa second; with a display (or on macOS), pyrender's default (pyglet) is left alone.

    Returns:
        The platform name: ``"egl"``, ``"osmesa"``, or ``"pyglet"`` (pyrender's default).

    Raises:
        RenderUnavailableError: Neither EGL nor OSMesa works headless; names the packages to install.
    """
    chosen = os.environ.get("PYOPENGL_PLATFORM")
    if chosen:
        return chosen
    if "OpenGL" in sys.modules or sys.platform == "darwin" or _has_display():
        # Too late to choose (OpenGL already imported) or a window system is there to use.
        return "pyglet"
    for name, works in (("egl", _egl_works), ("osmesa", _osmesa_works)):
        if works():
            os.environ["PYOPENGL_PLATFORM"] = name
            return name
    raise RenderUnavailableError(f"no headless OpenGL: neither EGL nor OSMesa could be initialised; {_INSTALL_HINT}")


def import_pyrender() -> ModuleType:
    """Select the OpenGL platform, then import and return ``pyrender``.

    Raises:
        RenderUnavailableError: pyrender is not installed, or no headless OpenGL works.
    """
    select_platform()
    try:
        import pyrender
    except ImportError as exc:
        raise RenderUnavailableError(
            f"rendering needs pyrender ({exc}); install the render extra: pip install 'morphkit[render]'"
        ) from None
    except Exception as exc:  # PyOpenGL raises plain errors when the platform library is broken
        raise RenderUnavailableError(f"pyrender could not load OpenGL ({exc}); {_INSTALL_HINT}") from None
    return pyrender


@contextlib.contextmanager
def offscreen_renderer(width: int, height: int) -> Iterator[Any]:
    """A ``pyrender.OffscreenRenderer`` of ``width`` x ``height`` pixels, released on exit.

    Raises:
        RenderUnavailableError: The OpenGL context cannot be created; names the packages to install.
    """
    pyrender = import_pyrender()
    try:
        renderer = pyrender.OffscreenRenderer(int(width), int(height))
    except Exception as exc:  # EGL/OSMesa failures surface as assorted RuntimeError/GLError types
        platform = os.environ.get("PYOPENGL_PLATFORM", "pyglet")
        raise RenderUnavailableError(
            f"cannot create an offscreen OpenGL context with {platform} ({type(exc).__name__}: {exc}); {_INSTALL_HINT}"
        ) from None
    try:
        yield renderer
    finally:
        renderer.delete()
