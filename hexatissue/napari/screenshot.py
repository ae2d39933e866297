"""The viewer's canvas as an RGBA image (and PNG), headless too.

``napari.Viewer.screenshot`` grabs the Qt OpenGL widget's frame buffer,
which is black on Qt's ``offscreen`` platform; rendering the vispy scene
canvas into its own frame buffer gives the same picture there and on a
screen.  Either way OpenGL needs a display: on a server run under
``xvfb-run`` (Qt's offscreen platform makes its GL contexts through the X
server's GLX).

Without one, the canvas has no OpenGL context and every GL call fails
(``glGetString`` returns NULL, framebuffer binds raise); raised inside a Qt
paint callback such an error ends the process (PyQt aborts on exceptions in
virtual methods, rc 134).  :func:`canvas_image` renders from Python, never
from a paint callback, and turns that failure into an
:class:`~hexatissue.errors.InputError` saying what to do.  An X server without GLX aborts already in
``napari.Viewer()`` (in vispy's Qt backend), before any helper can run.
"""
from __future__ import annotations

import numpy as np

from ..errors import InputError

__all__ = ["canvas_image"]


def canvas_image(viewer, path=None) -> np.ndarray:
    """``(rows, cols, 4)`` uint8 RGBA image of the viewer's canvas; written to ``path`` (PNG) when given.

    Parameters
    ----------
    viewer : napari.Viewer
        Shown or not (``show=False``).
    path : str or Path, optional
        PNG written atomically.
    """
    import cv2

    from ..io import atomic_path

    if getattr(viewer.window, "_qt_window", None) is None:
        raise InputError("viewer is closed: take the canvas image before viewer.close()")
    canvas = getattr(getattr(viewer.window, "_qt_viewer", None), "canvas", None)
    scene = getattr(canvas, "_scene_canvas", None)
    if scene is None:
        raise InputError("viewer has no vispy scene canvas to render (this napari version keeps it elsewhere); "
                         "use viewer.screenshot(canvas_only=True) on a screen")
    try:
        image = np.asarray(scene.render(), dtype=np.uint8)
    except (AttributeError, RuntimeError) as exc:  # vispy: a NULL GL string, or a GL call with no context
        raise InputError(f"viewer has no OpenGL context to render with (no display; {exc}): run under an X server "
                         f"with GLX, e.g. QT_QPA_PLATFORM=offscreen xvfb-run -a python ...") from exc
    if path is not None:
        png = cv2.imencode(".png", cv2.cvtColor(image, cv2.COLOR_RGBA2BGRA))[1]
        with atomic_path(path) as tmp:
            tmp.write_bytes(png.tobytes())
    return image


