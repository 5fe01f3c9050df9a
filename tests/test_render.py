"""Rendering of references (filmstrip PNG) and trials (GIF), with the expected-contact overlays."""

from __future__ import annotations

import importlib.util

import imageio.v3 as iio
import mujoco
import numpy as np
import pytest
from helpers import static_reference

from contactmpc.render import (
    draw_expected_contacts,
    filmstrip_frames,
    render_reference_filmstrip,
    render_trial_frames,
    render_trial_video,
    task_camera,
    video_times,
)

SIZE = (96, 128)


@pytest.fixture(scope="module")
def apple(scene_for):
    scene = scene_for("apple")
    return scene, static_reference(scene)


def _series(scene, steps: int = 10, dt: float = 0.1, seed: int = 0) -> dict[str, np.ndarray]:
    """``steps`` logged steps: the fingers flex linearly from home, random contacts."""
    q0 = scene.make_data().qpos.copy()
    q1 = q0.copy()
    q1[scene.index.hand_qpos[6:]] += 0.4
    links = len(scene.index.link_bodies)
    return {
        "time": np.arange(steps) * dt,
        "qpos": np.linspace(q0, q1, steps),
        "contacts": np.random.default_rng(seed).random((steps, links)) < 0.5,
    }


def test_filmstrip_writes_a_strip_of_panels(apple, tmp_path):
    scene, ref = apple
    path = render_reference_filmstrip(scene, ref, tmp_path / "strip.png", num_frames=5, size=SIZE)
    img = iio.imread(path)
    assert img.shape == (SIZE[0], 5 * SIZE[1] + 4 * 4, 3)
    assert img.reshape(-1, 3).std(axis=0).max() > 5.0, "the filmstrip is uniform"


def test_filmstrip_prefers_phase_boundaries(apple):
    _, ref = apple
    phases = [{"name": "reach", "start": 0.0, "end": 0.4}, {"name": "close", "start": 0.4, "end": 1.0}]
    picks = filmstrip_frames(ref, 7, phases)
    assert [name for _, name in picks] == ["reach", "close", "close (end)"]
    assert [round(float(ref.time[f]), 6) for f, _ in picks] == [0.0, 0.4, 1.0]
    assert [f for f, _ in filmstrip_frames(ref, 3)] == [0, 12, 25]


def test_contact_markers_change_pixels(apple, tmp_path):
    scene, ref = apple
    on = iio.imread(render_reference_filmstrip(scene, ref, tmp_path / "a.png", num_frames=2, size=SIZE))
    off = iio.imread(
        render_reference_filmstrip(scene, ref, tmp_path / "b.png", num_frames=2, size=SIZE, contacts=False)
    )
    assert (np.abs(on.astype(int) - off.astype(int)).max(axis=-1) > 30).sum() > 20

    # The spheres alone (coinciding points, so no line): one contact 10 cm in front of the camera.
    m, data = scene.plant_model, scene.make_data()
    links = len(scene.index.link_bodies)
    active = np.arange(links) == 0
    with mujoco.Renderer(m, *SIZE) as r:
        r.update_scene(data, task_camera(scene))
        plain = r.render().copy()
        cam = r.scene.camera[0]
        point = np.asarray(cam.pos) + 0.1 * np.asarray(cam.forward)
        lb, ob = scene.index.link_bodies[0], scene.index.object_bodies[0]
        link_point = np.zeros((links, 3))
        obj_point = np.zeros((links, 3))
        link_point[0] = data.xmat[lb].reshape(3, 3).T @ (point - data.xpos[lb])
        obj_point[0] = data.xmat[ob].reshape(3, 3).T @ (point - data.xpos[ob])
        draw_expected_contacts(r.scene, scene, data, active, link_point, obj_point, np.zeros(links, int))
        marked = r.render().copy()
    assert (np.abs(marked.astype(int) - plain.astype(int)).max(axis=-1) > 30).sum() > 20


def test_trial_video_gif_frames(apple, tmp_path):
    scene, ref = apple
    series = _series(scene)
    fps = 10
    path = render_trial_video(scene, series, ref, tmp_path / "trial.gif", fps=fps, size=SIZE)
    frames = iio.imread(path)
    duration = series["time"][-1] - series["time"][0]
    assert frames.shape == (round(duration * fps), *SIZE, 3)
    assert len(video_times(series["time"], fps, speed=3.0)) == round(duration * fps / 3.0)
    diffs = [np.abs(frames[i].astype(int) - frames[i + 1].astype(int)).max() for i in range(len(frames) - 1)]
    assert min(diffs) > 0, "consecutive video frames are identical"


def test_trial_video_rejects_unknown_formats(apple, tmp_path):
    scene, ref = apple
    with pytest.raises(ValueError, match="unsupported video format"):
        render_trial_video(scene, _series(scene, 2), ref, tmp_path / "trial.avi")
    if importlib.util.find_spec("imageio_ffmpeg") is None:
        with pytest.raises(RuntimeError, match="imageio-ffmpeg"):
            render_trial_video(scene, _series(scene, 2), ref, tmp_path / "trial.mp4")


def test_trial_frames_put_the_plant_above_the_reference(apple, tmp_path):
    """One panel per instant, the plant's row above the reference's (without ``reference``: the plant's
    alone); an instant between logged steps shows the step it holds."""
    scene, ref = apple
    series = _series(scene)
    path = render_trial_frames(scene, series, ref, tmp_path / "f.png", [0.0, 0.35, 0.9], size=SIZE)
    img = iio.imread(path)
    assert img.shape == (2 * SIZE[0] + 4, 3 * SIZE[1] + 2 * 4, 3)
    plant, reference = img[24 : SIZE[0]].astype(int), img[SIZE[0] + 4 + 24 :].astype(int)  # under the labels
    assert np.abs(plant - reference).max() > 0  # the fingers flexed in the plant, not in the reference
    held = render_trial_frames(scene, series, ref, tmp_path / "g.png", [0.3], size=SIZE, reference=False)
    again = render_trial_frames(scene, series, ref, tmp_path / "h.png", [0.35], size=SIZE, reference=False)
    assert iio.imread(held).shape == (SIZE[0], SIZE[1], 3)
    np.testing.assert_array_equal(iio.imread(held)[20:], iio.imread(again)[20:])  # 0.35 s holds 0.3's step
