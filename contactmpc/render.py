"""Offscreen rendering of scenes, references and trials with ``mujoco.Renderer``.

* :func:`render_scene`: the task's scene in its initial state (PNG).
* :func:`render_reference_filmstrip`: a 1 x N strip of reference frames with their expected contacts (PNG).
* :func:`render_trial_video`: a logged trial with expected and actual contacts (GIF, or MP4 with
  ``imageio-ffmpeg``).
* :func:`render_trial_frames`: a logged trial at chosen instants above the reference at the same instants
  (PNG), from the kept series alone (``python -m analysis.frames``).

Expected contacts are drawn as small spheres (link point green, object point red, joined by a thin
line); links actually touching the object are tinted orange. Text is drawn with Pillow (a matplotlib
dependency). Set ``MUJOCO_GL=egl`` (headless GPU/Mesa) or ``osmesa`` before MuJoCo creates its first
context; this module and ``launch.py`` default it to ``egl`` where libEGL loads, else to ``disable``
(:mod:`contactmpc.gl`), with which MuJoCo imports but cannot render: a renderer then raises one line saying
what to install or set.
"""

from __future__ import annotations

from contactmpc.gl import default_gl, require_gl

default_gl()  # headless (egl) by default where libEGL loads; read when MuJoCo is first imported

from collections.abc import Mapping, Sequence  # noqa: E402
from pathlib import Path  # noqa: E402

import imageio.v3 as iio  # noqa: E402
import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from PIL import Image, ImageDraw, ImageFont  # noqa: E402

from contactmpc.control.track import ReferenceTrack  # noqa: E402
from contactmpc.reference.data import Reference  # noqa: E402
from contactmpc.scene import Scene  # noqa: E402

LINK_POINT_RGBA = (0.1, 0.9, 0.2, 1.0)
"""Expected contact point on the link (green)."""
OBJECT_POINT_RGBA = (0.95, 0.1, 0.1, 1.0)
"""Expected contact point on the object (red)."""
LINE_RGBA = (1.0, 1.0, 0.2, 1.0)
"""Line joining an expected link point to its object point (yellow)."""
IN_CONTACT_RGBA = (1.0, 0.55, 0.0, 1.0)
"""Tint of links actually touching the object (orange)."""
MARKER_RADIUS = 0.005
"""Radius of the contact spheres (m)."""


def make_camera(
    lookat: Sequence[float], distance: float, azimuth: float, elevation: float
) -> mujoco.MjvCamera:
    """A free camera orbiting ``lookat``.

    Args:
        lookat: (3,) point the camera looks at (m).
        distance: distance from ``lookat`` (m).
        azimuth: degrees about the world z axis.
        elevation: degrees above the horizon (negative looks down).
    """
    cam = mujoco.MjvCamera()
    cam.type = mujoco.mjtCamera.mjCAMERA_FREE
    cam.lookat[:] = lookat
    cam.distance = distance
    cam.azimuth = azimuth
    cam.elevation = elevation
    return cam


def task_camera(scene: Scene) -> mujoco.MjvCamera:
    """The task's default view (``Task.view``: lookat, distance, azimuth, elevation)."""
    return make_camera(**scene.task.view)


def render_frame(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    camera: mujoco.MjvCamera,
    size: tuple[int, int] = (480, 640),
    renderer: mujoco.Renderer | None = None,
) -> np.ndarray:
    """Render one RGB frame.

    Args:
        model: the model of ``data``.
        data: the state to show (kinematics must be current).
        camera: the camera to render from.
        size: (height, width) in pixels.
        renderer: a renderer to reuse (its size wins), or ``None`` to make a temporary one.

    Returns:
        (H, W, 3) uint8 image.
    """
    own = renderer is None
    r = _renderer(model, size) if own else renderer
    try:
        r.update_scene(data, camera)
        return r.render().copy()
    finally:
        if own:
            r.close()


def _renderer(model: mujoco.MjModel, size: Sequence[int]) -> mujoco.Renderer:
    """``mujoco.Renderer(model, *size)``, or :class:`~contactmpc.gl.NoGLError` where OpenGL is off."""
    require_gl()
    return mujoco.Renderer(model, *size)


# ---------------------------------------------------------------------------------------- overlays
def _add_geom(scn: mujoco.MjvScene) -> mujoco.MjvGeom | None:
    """Claim the next user geom of ``scn`` (``None`` when the scene is full)."""
    if scn.ngeom >= scn.maxgeom:
        return None
    scn.ngeom += 1
    return scn.geoms[scn.ngeom - 1]


def _sphere(scn: mujoco.MjvScene, pos: np.ndarray, rgba: Sequence[float], radius: float) -> None:
    g = _add_geom(scn)
    if g is not None:
        size = np.array([radius, 0.0, 0.0])
        mujoco.mjv_initGeom(g, mujoco.mjtGeom.mjGEOM_SPHERE, size, pos, np.eye(3).ravel(), np.asarray(rgba))


def _line(scn: mujoco.MjvScene, a: np.ndarray, b: np.ndarray, rgba: Sequence[float]) -> None:
    g = _add_geom(scn) if np.linalg.norm(b - a) > 1e-6 else None
    if g is not None:
        mujoco.mjv_initGeom(
            g, mujoco.mjtGeom.mjGEOM_LINE, np.zeros(3), np.zeros(3), np.eye(3).ravel(), np.asarray(rgba)
        )
        mujoco.mjv_connector(g, mujoco.mjtGeom.mjGEOM_LINE, 2.0, a, b)


def contact_points_world(
    scene: Scene,
    data: mujoco.MjData,
    link_point: np.ndarray,
    object_point: np.ndarray,
    object_body: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """World positions of expected contact points, from link-local and object-local points.

    Args:
        scene: the scene (``data`` must be of its plant model, kinematics current).
        link_point: (L, 3) points in the frames of ``scene.index.link_bodies``.
        object_point: (L, 3) points in the frames of the object bodies ``object_body``.
        object_body: (L,) indices into ``scene.index.object_bodies``.

    Returns:
        (L, 3) link points and (L, 3) object points, in world coordinates.
    """
    lb = scene.index.link_bodies
    ob = scene.index.object_bodies[np.asarray(object_body, int)]
    rot_l, rot_o = data.xmat[lb].reshape(-1, 3, 3), data.xmat[ob].reshape(-1, 3, 3)
    world_l = data.xpos[lb] + np.einsum("lij,lj->li", rot_l, link_point)
    world_o = data.xpos[ob] + np.einsum("lij,lj->li", rot_o, object_point)
    return world_l, world_o


def draw_expected_contacts(
    scn: mujoco.MjvScene,
    scene: Scene,
    data: mujoco.MjData,
    active: np.ndarray,
    link_point: np.ndarray,
    object_point: np.ndarray,
    object_body: np.ndarray,
    radius: float = MARKER_RADIUS,
) -> None:
    """Add the active expected contacts to ``scn`` (after ``update_scene``) as spheres and lines.

    Args:
        active: (L,) bool; the other arrays as in :func:`contact_points_world`.
    """
    world_l, world_o = contact_points_world(scene, data, link_point, object_point, object_body)
    for li in np.flatnonzero(active):
        _sphere(scn, world_l[li], LINK_POINT_RGBA, radius)
        _sphere(scn, world_o[li], OBJECT_POINT_RGBA, radius)
        _line(scn, world_l[li], world_o[li], LINE_RGBA)


def tint_links(
    scn: mujoco.MjvScene, scene: Scene, links: np.ndarray, rgba: Sequence[float] = IN_CONTACT_RGBA
) -> None:
    """Recolour the model geoms of the links flagged in ``links`` ((L,) bool) in ``scn``."""
    if not np.any(links):
        return
    for i in range(scn.ngeom):
        g = scn.geoms[i]
        if g.objtype == mujoco.mjtObj.mjOBJ_GEOM and g.objid >= 0:
            li = scene.index.link_of_geom[g.objid]
            if li >= 0 and links[li]:
                g.rgba[:] = rgba


def _font(size: int) -> ImageFont.ImageFont:
    try:
        return ImageFont.load_default(size=size)
    except TypeError:  # Pillow < 10.1 has only the fixed bitmap font
        return ImageFont.load_default()


def label(img: np.ndarray, lines: Sequence[str], size: int = 14) -> np.ndarray:
    """Draw ``lines`` of text in the image's top-left corner on a dark box.

    Args:
        img: (H, W, 3) uint8 image.

    Returns:
        (H, W, 3) uint8 copy with the text.
    """
    pil = Image.fromarray(img)
    draw = ImageDraw.Draw(pil)
    font = _font(size)
    text = "\n".join(lines)
    box = draw.multiline_textbbox((4, 3), text, font=font)
    draw.rectangle((box[0] - 3, box[1] - 2, box[2] + 3, box[3] + 2), fill=(0, 0, 0))
    draw.multiline_text((4, 3), text, fill=(255, 255, 255), font=font)
    return np.asarray(pil)


# ---------------------------------------------------------------------------------------- reference
def filmstrip_frames(
    reference: Reference, num_frames: int, phases: Sequence[Mapping] | None = None
) -> list[tuple[int, str]]:
    """Frames to show: phase boundaries when ``phases`` are given, else evenly spaced.

    Args:
        reference: the reference (``T`` frames).
        num_frames: the most frames to pick (phase boundaries are thinned to it).
        phases: [{"name", "start", "end"}] in demonstration time (``reference.time``).

    Returns:
        (frame index, phase name or "") per picked frame, in time order.
    """
    time = np.asarray(reference.time)
    if not phases:
        idx = np.unique(np.round(np.linspace(0, len(time) - 1, max(1, num_frames))).astype(int))
        return [(int(i), "") for i in idx]
    marks = [(float(p["start"]), str(p["name"])) for p in phases]
    marks.append((float(phases[-1]["end"]), f"{phases[-1]['name']} (end)"))
    keep = np.unique(np.round(np.linspace(0, len(marks) - 1, min(num_frames, len(marks)))).astype(int))
    frames = np.clip(np.searchsorted(time, [marks[k][0] - 1e-9 for k in keep]), 0, len(time) - 1)
    return [(int(f), marks[k][1]) for f, k in zip(frames, keep, strict=True)]


def render_reference_filmstrip(
    scene: Scene,
    reference: Reference,
    path: str | Path,
    num_frames: int = 7,
    size: tuple[int, int] = (240, 320),
    phases: Sequence[Mapping] | None = None,
    contacts: bool = True,
) -> Path:
    """Render a 1 x N strip of reference frames, with expected contacts, as one PNG.

    Frames are the phase boundaries of ``phases`` (default ``reference.meta["phases"]``, thinned to
    ``num_frames``) or ``num_frames`` evenly spaced frames. Each panel is labelled with its time
    (demonstration seconds) and phase.

    Args:
        scene: the scene of the reference's task.
        reference: the reference to show.
        path: the PNG to write (parent folders are created).
        num_frames: the number of panels (at most).
        size: (height, width) of one panel in pixels.
        phases: [{"name", "start", "end"}] overriding ``reference.meta["phases"]``.
        contacts: draw the expected contact points.

    Returns:
        The path written; the image is (H, N*W + 4*(N-1), 3).
    """
    phases = reference.meta.get("phases") if phases is None else phases
    picks = filmstrip_frames(reference, num_frames, phases)
    m, data, cam = scene.plant_model, mujoco.MjData(scene.plant_model), task_camera(scene)
    renderer = _renderer(m, size)
    panels = []
    try:
        for f, name in picks:
            data.qpos[scene.index.hand_qpos] = reference.hand_qpos[f]
            data.qpos[scene.index.object_qpos] = reference.object_qpos[f]
            mujoco.mj_forward(m, data)
            renderer.update_scene(data, cam)
            if contacts:
                draw_expected_contacts(
                    renderer.scene, scene, data, reference.contact_active[f], reference.contact_link_point[f],
                    reference.contact_object_point[f], reference.contact_object_body[f],
                )  # fmt: skip
            text = [f"t = {reference.time[f]:.2f} s"] + ([name] if name else [])
            panels.append(label(renderer.render().copy(), text))
    finally:
        renderer.close()
    strip = _join(panels, axis=1)
    return write_png(strip, path)


def _join(images: Sequence[np.ndarray], axis: int, gap: int = 4) -> np.ndarray:
    """``images`` (each (H, W, 3) uint8) side by side (``axis=1``) or stacked (``axis=0``), ``gap`` white
    pixels between neighbours."""
    shape = list(images[0].shape)
    shape[axis] = gap
    white = np.full(shape, 255, np.uint8)
    return np.concatenate([x for img in images for x in (white, img)][1:], axis=axis)


def _held(time: np.ndarray, t: float) -> int:
    """The index of the last of ``time`` (increasing) at or before ``t`` (the first, before them all)."""
    return max(0, int(np.searchsorted(time, t + 1e-9, side="right")) - 1)


def write_png(img: np.ndarray, path: str | Path) -> Path:
    """Write an (H, W, 3) uint8 image as a PNG, creating the directory; returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    iio.imwrite(path, img)
    return path


# ---------------------------------------------------------------------------------------- trials
def _as_track(scene: Scene, track_or_reference: ReferenceTrack | Reference) -> ReferenceTrack:
    if isinstance(track_or_reference, ReferenceTrack):
        return track_or_reference
    return ReferenceTrack.build(
        track_or_reference, scene.task.layout, scene.task.time_scale, scene.planner_timestep, 0.0
    )


def video_times(time: np.ndarray, fps: float, speed: float = 1.0) -> np.ndarray:
    """Control times of the video frames: ``fps`` frames per ``speed`` seconds of control time.

    Args:
        time: (N,) logged control times, increasing.

    Returns:
        (K,) frame times, ``K = max(1, round((time[-1] - time[0]) * fps / speed))``.
    """
    k = max(1, int(round((time[-1] - time[0]) * fps / speed)))
    return time[0] + np.arange(k) * speed / fps


def render_trial_video(
    scene: Scene,
    series: Mapping[str, np.ndarray],
    track_or_reference: ReferenceTrack | Reference,
    path: str | Path,
    fps: float = 30,
    size: tuple[int, int] = (360, 480),
    speed: float = 1.0,
) -> Path:
    """Render a logged trial as a GIF or MP4, with expected (spheres) and actual (tint) contacts.

    Each video frame shows the last logged step at or before its control time (zero-order hold),
    with the expected contacts of that time on the track's grid and the logged contacts.

    Args:
        scene: the trial's scene.
        series: the trial's log arrays: ``time`` (N,), ``qpos`` (N, nq), optionally ``contacts``
            (N, L) bool.
        track_or_reference: the trial's :class:`ReferenceTrack`, or its :class:`Reference` (a track
            is built with the task's ``time_scale``).
        path: ``.gif`` (Pillow) or ``.mp4`` (needs ``imageio-ffmpeg``).
        fps: video frames per second.
        size: (height, width) in pixels (use multiples of 16 for MP4).
        speed: control seconds per video second.

    Returns:
        The path written.

    Raises:
        RuntimeError: ``.mp4`` requested without ``imageio-ffmpeg`` installed.
        ValueError: an unsupported extension.
    """
    path = Path(path)
    writer = _video_writer(path)
    track = _as_track(scene, track_or_reference)
    time, qpos = np.asarray(series["time"], float), np.asarray(series["qpos"], float)
    touching = series.get("contacts")
    m, data, cam = scene.plant_model, mujoco.MjData(scene.plant_model), task_camera(scene)
    renderer = _renderer(m, size)
    frames = []
    try:
        for t in video_times(time, fps, speed):
            k = _held(time, t)
            links = None if touching is None else np.asarray(touching[k], bool)
            text = f"t = {time[k]:.2f} s"
            frames.append(
                _panel(renderer, scene, data, cam, qpos[k], links, track, track.index(time[k]), text)
            )
    finally:
        renderer.close()
    path.parent.mkdir(parents=True, exist_ok=True)
    writer(path, np.stack(frames), fps)
    return path


def _panel(
    renderer: mujoco.Renderer,
    scene: Scene,
    data: mujoco.MjData,
    camera: mujoco.MjvCamera,
    qpos: np.ndarray,
    links: np.ndarray | None,
    track: ReferenceTrack,
    i: int,
    text: str,
    follow: int = -1,
) -> np.ndarray:
    """One labelled frame of the plant at ``qpos``: the ``links`` touching ((L,) bool, or None) tinted,
    the track's expected contacts of grid step ``i`` drawn; ``follow`` >= 0: the camera looks at that
    body first."""
    data.qpos[:] = qpos
    mujoco.mj_forward(scene.plant_model, data)
    if follow >= 0:
        camera.lookat[:] = data.xpos[follow]
    renderer.update_scene(data, camera)
    if links is not None:
        tint_links(renderer.scene, scene, links)
    draw_expected_contacts(
        renderer.scene, scene, data, track.contact_active[i], track.contact_link_point[i],
        track.contact_object_point[i], track.contact_object_body[i],
    )  # fmt: skip
    return label(renderer.render().copy(), [text])


def render_trial_frames(
    scene: Scene,
    series: Mapping[str, np.ndarray],
    track_or_reference: ReferenceTrack | Reference,
    path: str | Path,
    times: Sequence[float],
    size: tuple[int, int] = (240, 320),
    zoom: float = 1.0,
    reference: bool = True,
) -> Path:
    """Render a logged trial at control ``times`` as one PNG: a row of the plant as logged (the last
    logged step at or before each time, touching links tinted, the expected contacts of that time drawn)
    above a row of the reference at the same times (its hand and expected object pose, its contacts).

    Args:
        scene: the trial's scene.
        series: the trial's log arrays: ``time`` (N,), ``qpos`` (N, nq), optionally ``contacts`` (N, L).
        track_or_reference: the trial's :class:`ReferenceTrack`, or its :class:`Reference`.
        path: the PNG to write (parent folders are created).
        times: control times (s) of the panels; each is shown at the logged step it holds.
        size: (height, width) of one panel in pixels.
        zoom: the task camera's distance times this, looking at the object's first body as each panel
            (of either row) has it; 1: the task's view as it is.
        reference: add the reference's row.

    Returns:
        The path written; the image is (R*H + 4*(R-1), N*W + 4*(N-1), 3) for R rows and N times.
    """
    track = _as_track(scene, track_or_reference)
    time, qpos = np.asarray(series["time"], float), np.asarray(series["qpos"], float)
    touching = series.get("contacts")
    m, data, cam = scene.plant_model, mujoco.MjData(scene.plant_model), task_camera(scene)
    cam.distance *= zoom
    body = int(scene.index.object_bodies[0]) if len(scene.index.object_bodies) else -1
    follow = body if zoom != 1.0 else -1
    renderer = _renderer(m, size)
    rows: list[list[np.ndarray]] = [[], []]
    try:
        for t in times:
            k = _held(time, t)
            i, f = track.index(time[k]), _held(track.hand_times, time[k])
            plant = (qpos[k], None if touching is None else np.asarray(touching[k], bool), "")
            kept = qpos[k].copy()  # the reference's hand and object in the plant's configuration
            kept[scene.index.hand_qpos] = track.hand_qpos[f]
            kept[scene.index.object_qpos] = track.object_qpos[i]
            shown = [plant] + ([(kept, None, "reference, ")] if reference else [])
            for row, (q, links, name) in zip(rows, shown, strict=False):
                text = f"{name}t = {time[k]:.2f} s"
                row.append(_panel(renderer, scene, data, cam, q, links, track, i, text, follow))
    finally:
        renderer.close()
    return write_png(_join([_join(row, axis=1) for row in rows if row], axis=0), path)


def _video_writer(path: Path):
    """A function ``(path, frames (K, H, W, 3) uint8, fps) -> None`` for the path's extension."""
    ext = path.suffix.lower()
    if ext == ".gif":
        return lambda p, frames, fps: iio.imwrite(p, frames, duration=1000.0 / fps, loop=0)
    if ext == ".mp4":
        try:
            import imageio_ffmpeg  # noqa: F401
        except ImportError as err:
            raise RuntimeError(
                f"writing {path.name} needs imageio-ffmpeg (pip install imageio-ffmpeg); write a .gif instead"
            ) from err
        import imageio.v2 as iio2

        return lambda p, frames, fps: iio2.mimwrite(p, list(frames), fps=fps, macro_block_size=1)
    raise ValueError(f"unsupported video format {ext!r} for {path} (use .gif or .mp4)")
