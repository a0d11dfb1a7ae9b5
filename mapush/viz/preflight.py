"""Checks that run before anything renders: an OpenGL backend for MuJoCo's offscreen renderer, a display for the
viewer, and the video settings. Each failure is one BadInput line naming what to install or set.

MuJoCo reads `MUJOCO_GL` once, when it is imported, and an unusable backend can break `import mujoco` itself.
So when MuJoCo is not imported yet, each candidate backend is first tried in a child process and the first that
renders is set for this one; when it is, a tiny renderer is built here and a failure names the variable to set.
"""

from __future__ import annotations

import functools
import importlib.util
import os
import subprocess
import sys

from mapush.children import dies_with_parent
from mapush.errors import BadInput
from mapush.schema import check_config

HEADLESS_BACKENDS = ("egl", "osmesa")
"""Tried in this order when MUJOCO_GL is unset: Mesa's EGL (llvmpipe on a CPU, the GPU's driver where one is), then
OSMesa."""
INSTALL_GL = (
    "install Mesa's EGL (Debian: apt-get install libegl1 libegl-mesa0 libopengl0 libgl1-mesa-dri; bash tools/setup.sh "
    "does it as root) or OSMesa (apt-get install libosmesa6), or set MUJOCO_GL to a backend that works here"
)
INSTALL_PYTHON = "pip install -e '.[render]'"
PROBE_TIMEOUT_S = 60


def render_one_frame() -> None:
    """Build MuJoCo's offscreen renderer on a one-sphere model and draw a 16 x 16 frame (raises where it cannot)."""
    import mujoco

    model = mujoco.MjModel.from_xml_string('<mujoco><worldbody><geom type="sphere" size=".1"/></worldbody></mujoco>')
    renderer = mujoco.Renderer(model, 16, 16)
    try:
        renderer.update_scene(mujoco.MjData(model))
        renderer.render()
    finally:
        renderer.close()


def _missing_modules(modules: dict[str, str]) -> list[str]:
    """The pip names of `modules` ({import name: pip name}) that cannot be imported."""
    return [pip for name, pip in modules.items() if importlib.util.find_spec(name) is None]


def _renders_in_child(backend: str) -> bool:
    """Whether a fresh interpreter with `MUJOCO_GL=backend` can build MuJoCo's renderer and draw a frame."""
    env = {**os.environ, "MUJOCO_GL": backend}
    env.pop("PYOPENGL_PLATFORM", None)  # MuJoCo sets the one that goes with its backend
    try:
        done = subprocess.run(
            [sys.executable, "-c", f"from {__name__} import render_one_frame; render_one_frame()"],
            env=env,
            capture_output=True,
            timeout=PROBE_TIMEOUT_S,
            check=False,
            preexec_fn=dies_with_parent(),
        )
    except subprocess.TimeoutExpired:
        return False
    return done.returncode == 0


def _renders_here() -> str:
    """'' when this process (MuJoCo already imported) can render offscreen; else the error's first line."""
    try:
        render_one_frame()
    except Exception as err:  # MuJoCo raises FatalError, ImportError, RuntimeError... depending on the backend
        lines = str(err).strip().splitlines()
        return f"{type(err).__name__}: {lines[0] if lines else ''}"
    return ""


@functools.cache
def require_offscreen_gl() -> str:
    """Make sure MuJoCo can render offscreen in this process; returns the backend (the value of MUJOCO_GL).

    Raises:
        BadInput: naming the packages to install, when no backend renders.
    """
    missing = _missing_modules({"OpenGL": "PyOpenGL", "av": "av"})
    if missing:
        raise BadInput(f"rendering needs the Python packages {', '.join(missing)}; install them: {INSTALL_PYTHON}")
    chosen = os.environ.get("MUJOCO_GL", "")
    if "mujoco" in sys.modules:
        error = _renders_here()
        if error:
            shown = chosen or "unset (glfw: a window on a display)"
            raise BadInput(f"MuJoCo cannot render offscreen here ({error}; MUJOCO_GL is {shown}); {INSTALL_GL}")
        return chosen
    candidates = (chosen,) if chosen else HEADLESS_BACKENDS
    for backend in candidates:
        if _renders_in_child(backend):
            os.environ["MUJOCO_GL"] = backend
            return backend
    raise BadInput(f"no OpenGL backend renders here (MUJOCO_GL tried: {', '.join(candidates)}); {INSTALL_GL}")


def require_display() -> None:
    """Make sure MuJoCo's native viewer can open a window: glfw installed and, on Linux, a display to open it on."""
    missing = _missing_modules({"glfw": "glfw", "OpenGL": "PyOpenGL"})
    if missing:
        raise BadInput(f"the viewer needs the Python packages {', '.join(missing)}; install them: {INSTALL_PYTHON}")
    if sys.platform.startswith("linux") and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        raise BadInput(
            "no display to open the viewer on (DISPLAY and WAYLAND_DISPLAY are unset); run it on a desktop, or "
            "record a video instead: mapush eval RUN --video"
        )


def check_video_config(cfg: dict) -> None:
    """BadInput for a video setting out of range: `log.video_interval` and the `log.video` block, by the config's
    one rule table (`mapush.schema.RULES`)."""
    check_config({"log": cfg["log"]})


def prepare_training_video(cfg) -> None:
    """Before a training run is built: check the video settings and, when `log.video_interval` > 0, the renderer."""
    from mapush.config import to_plain  # late: the probe's child imports this module and needs no Hydra

    plain = cfg if isinstance(cfg, dict) else to_plain(cfg)
    check_video_config(plain)
    if int(plain["log"]["video_interval"]) > 0:
        require_offscreen_gl()
