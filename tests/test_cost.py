"""The vectorised cost against direct per-state computations from MjData."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from contactmpc.control.cost import TrackingCost
from contactmpc.control.rollout import RolloutEngine
from contactmpc.control.track import ReferenceTrack
from tests.helpers import static_reference


@pytest.mark.parametrize("task", ["apple", "stapler"])
def test_contact_and_object_terms_match_mjdata(scene_for, task):
    scene = scene_for(task)
    m = scene.planner_model
    ref = static_reference(scene, active_links=21)
    rng = np.random.default_rng(3)
    ref.contact_active[:] = rng.random(ref.contact_active.shape) < 0.5
    ref.contact_link_point[:] = rng.normal(0, 0.02, ref.contact_link_point.shape)
    ref.contact_object_point[:] = rng.normal(0, 0.02, ref.contact_object_point.shape)
    ref.contact_object_body[:] = rng.integers(0, len(scene.task.object_bodies), ref.contact_object_body.shape)
    track = ReferenceTrack.build(ref, scene.task.layout, scene.task.time_scale, m.opt.timestep, 1.0)
    cost = TrackingCost(lambda_o=1.0, lambda_c=1.0, lambda_v=0.1)
    cost.bind(scene, track)

    data = scene.make_data(m)
    nstate = mujoco.mj_stateSize(m, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    x0 = np.empty(nstate)
    mujoco.mj_getState(m, data, x0, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    S, H = 3, 20
    ctrl = scene.task.hand_home + rng.normal(0, 0.3, (S, H, m.nu))
    with RolloutEngine(m, nthread=1) as engine:
        state, sensordata, diverged = engine.run(x0, ctrl)
    assert not diverged.any()
    window = track.window(0.3, H)
    terms = cost(sensordata, window)
    contact = cost.contact_term(sensordata, window)

    idx = scene.index
    checked = 0
    for s in range(S):
        for h in (1, 7, H - 1):  # sensordata row h is the state after h steps
            mujoco.mj_setState(m, data, state[s, h - 1], mujoco.mjtState.mjSTATE_FULLPHYSICS)
            mujoco.mj_forward(m, data)
            g = window.start + h
            direct = 0.0
            for link in range(len(idx.link_bodies)):
                if not track.contact_active[g, link]:
                    continue
                lb = idx.link_bodies[link]
                ob = idx.object_bodies[track.contact_object_body[g, link]]
                xl = data.xpos[lb] + data.xmat[lb].reshape(3, 3) @ track.contact_link_point[g, link]
                xo = data.xpos[ob] + data.xmat[ob].reshape(3, 3) @ track.contact_object_point[g, link]
                direct += float(np.sum((xl - xo) ** 2))
            assert contact[s, h] == pytest.approx(direct, rel=1e-9, abs=1e-12)
            assert terms["contact"][s, h] == pytest.approx(direct, rel=1e-9, abs=1e-12)
            err = scene.task.layout.error(scene.object_qpos(data), track.object_qpos[g])
            direct_obj = err.position**2 + cost.rotation_weight * err.rotation**2
            direct_obj += cost.articulation_weight * err.articulation**2
            assert terms["object"][s, h] == pytest.approx(direct_obj, rel=1e-7, abs=1e-12)
            vel = 0.1 * np.sum(data.qvel[idx.hand_dof] ** 2)
            assert terms["velocity"][s, h] == pytest.approx(vel, rel=1e-9, abs=1e-12)
            checked += 1
    assert checked == 3 * S
    assert contact.max() > 0


def test_object_only_cost_has_no_contact_term(scene_for):
    scene = scene_for("apple")
    ref = static_reference(scene)
    track = ReferenceTrack.build(ref, scene.task.layout, 5.0, 0.01, 1.0)
    cost = TrackingCost(lambda_c=0.0)
    cost.bind(scene, track)
    sd = np.zeros((2, 5, scene.planner_model.nsensordata))
    sd[..., scene.index.object_qo[3]] = 1.0  # unit quaternions
    assert np.all(cost(sd, track.window(0.0, 5))["contact"] == 0.0)


@pytest.mark.parametrize("task", ["stapler", "doorknob"])
def test_surface_and_clearance_terms_match_geom_distance(scene_for, task):
    """The surface and clearance terms from the scene's geomdist sensors against ``mj_geomDistance`` per
    state. Surface: each expected link's smallest distance to the geoms of the object body its contact is
    expected on, clipped at 0 from below, squared and summed. Clearance: each link whose first expected
    contact is still to come, ``max(clearance - d, 0)^2`` with ``d`` its distance to the nearest object
    geom. Both weighted by ``lambda_c`` times their own weight."""
    cutoff, clearance = 0.05, 0.03
    scene = scene_for(task, f"scene.link_distance_cutoff={cutoff}")
    m = scene.planner_model
    idx = scene.index
    assert idx.link_object_dist.shape[0] == len(idx.link_bodies) and idx.link_object_dist.shape[1] > 0
    ref = static_reference(scene, active_links=21)
    rng = np.random.default_rng(5)
    ref.contact_active[:] = rng.random(ref.contact_active.shape) < 0.5
    ref.contact_active[:, :3] = False  # never expected: kept clear throughout
    ref.contact_active[: len(ref.contact_active) // 2, 3:8] = False  # first expected halfway
    ref.contact_object_body[:] = rng.integers(0, len(scene.task.object_bodies), ref.contact_object_body.shape)
    track = ReferenceTrack.build(ref, scene.task.layout, scene.task.time_scale, m.opt.timestep, 1.0)
    cost = TrackingCost(lambda_c=2.0, surface_weight=3.0, clearance_weight=5.0, clearance=clearance)
    cost.bind(scene, track)

    data = scene.make_data(m)
    x0 = np.empty(mujoco.mj_stateSize(m, mujoco.mjtState.mjSTATE_FULLPHYSICS))
    mujoco.mj_getState(m, data, x0, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    S, H = 3, 20
    ctrl = scene.task.hand_home + rng.normal(0, 0.3, (S, H, m.nu))
    with RolloutEngine(m, nthread=1) as engine:
        state, sensordata, _ = engine.run(x0, ctrl)
    window = track.window(0.3, H)
    surface = cost.surface_term(sensordata, window)
    clear = cost.clearance_term(sensordata, window)
    terms = cost(sensordata, window)
    np.testing.assert_array_equal(terms["surface"], 2.0 * 3.0 * surface)
    np.testing.assert_array_equal(terms["clearance"], 2.0 * 5.0 * clear)

    geoms = [
        g
        for g in range(m.ngeom)
        if m.geom_bodyid[g] in idx.object_bodies and (m.geom_contype[g] or m.geom_conaffinity[g])
    ]
    active = track.contact_active
    first = [
        int(np.argmax(active[:, k])) if active[:, k].any() else len(active) for k in range(active.shape[1])
    ]
    fromto = np.zeros(6)
    distances, clear_pairs = [], 0
    for s in range(S):
        for h in (1, 7, H - 1):
            mujoco.mj_setState(m, data, state[s, h - 1], mujoco.mjtState.mjSTATE_FULLPHYSICS)
            mujoco.mj_forward(m, data)
            g = window.start + h
            direct_surface = direct_clear = 0.0
            for link in range(active.shape[1]):
                dist = {
                    o: mujoco.mj_geomDistance(m, data, idx.link_geoms[link], o, cutoff, fromto) for o in geoms
                }
                if active[g, link]:
                    body = idx.object_bodies[track.contact_object_body[g, link]]
                    d = min(v for o, v in dist.items() if m.geom_bodyid[o] == body)
                    distances.append(d)
                    direct_surface += max(d, 0.0) ** 2
                if g < first[link]:
                    clear_pairs += 1
                    direct_clear += max(clearance - min(dist.values()), 0.0) ** 2
            assert surface[s, h] == pytest.approx(direct_surface, rel=1e-9, abs=1e-15)
            assert clear[s, h] == pytest.approx(direct_clear, rel=1e-9, abs=1e-15)
    assert min(distances) < cutoff  # some link within the cutoff: not every distance saturated
    assert clear_pairs > 0 and clear.max() > 0.0  # some link not yet expected within the margin


def test_clearance_term_is_the_same_read_only_as_far_as_its_margin(scene_for):
    """The clearance term reads the same from distances read up to its margin (``scene.link_distance_cutoff``
    = ``cost.clearance``, as the method reads them) as from distances read up to 5 cm, bit for bit (a link
    farther than the margin adds nothing either way), so the tighter cutoff changes no trial; a cutoff short
    of the margin is refused, naming it."""
    clearance = 0.03
    terms = []
    for cutoff in (0.05, clearance):
        scene = scene_for("stapler", f"scene.link_distance_cutoff={cutoff}")
        m = scene.planner_model
        ref = static_reference(scene, active_links=21)
        ref.contact_active[:] = False
        ref.contact_active[len(ref.contact_active) // 2 :, 3:8] = True
        track = ReferenceTrack.build(ref, scene.task.layout, scene.task.time_scale, m.opt.timestep, 1.0)
        data = scene.make_data(m)
        x0 = np.empty(mujoco.mj_stateSize(m, mujoco.mjtState.mjSTATE_FULLPHYSICS))
        mujoco.mj_getState(m, data, x0, mujoco.mjtState.mjSTATE_FULLPHYSICS)
        rng = np.random.default_rng(5)
        ctrl = scene.task.hand_home + rng.normal(0, 0.3, (3, 20, m.nu))
        with RolloutEngine(m, nthread=1) as engine:
            _, sensordata, _ = engine.run(x0, ctrl)
        cost = TrackingCost(clearance_weight=1.0, clearance=clearance)
        cost.bind(scene, track)
        terms.append(cost.clearance_term(sensordata, track.window(0.3, 20)))
    np.testing.assert_array_equal(terms[0], terms[1])
    assert terms[0].max() > 0.0  # some link within the margin
    with pytest.raises(ValueError, match="scene.link_distance_cutoff is 0.03"):
        TrackingCost(clearance_weight=1.0, clearance=0.04).bind(scene, track)


def test_clearance_links_hold_every_link_off_until_the_reference_has_that_many(scene_for):
    """``clearance_links=k``: the clearance term keeps a link off until the reference first expects k links
    at once, or until the link's own first expected contact if later; 0 (the default) is each link's own
    first expected contact, bit for bit; a k the reference never reaches keeps every link off throughout."""
    scene = scene_for("stapler", "scene.link_distance_cutoff=0.5")
    m = scene.planner_model
    ref = static_reference(scene, active_links=21)
    ref.contact_active[:] = False
    n = len(ref.contact_active)
    a, b = n // 4, n // 2
    ref.contact_active[a:, 0] = True  # one link from a quarter in
    ref.contact_active[b:, 1:4] = True  # four at once from halfway
    ref.contact_active[3 * n // 4 :, 4] = True  # a fifth later still
    track = ReferenceTrack.build(ref, scene.task.layout, scene.task.time_scale, m.opt.timestep, 1.0)
    data = scene.make_data(m)
    x0 = np.empty(mujoco.mj_stateSize(m, mujoco.mjtState.mjSTATE_FULLPHYSICS))
    mujoco.mj_getState(m, data, x0, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    rng = np.random.default_rng(7)
    H = len(track.contact_active) - 1
    ctrl = scene.task.hand_home + rng.normal(0, 0.3, (2, H, m.nu))
    with RolloutEngine(m, nthread=1) as engine:
        _, sensordata, _ = engine.run(x0, ctrl)
    window = track.window(0.0, H)

    def clearance(**kw):
        cost = TrackingCost(clearance_weight=1.0, clearance=0.5, **kw)  # 50 cm: every link inside it
        cost.bind(scene, track)
        return cost.clearance_term(sensordata, window), cost._before_first

    own, own_first = clearance()
    np.testing.assert_array_equal(own, clearance(clearance_links=0)[0])
    held, held_first = clearance(clearance_links=4)
    grid = track.contact_active
    start = int(np.argmax(grid.sum(axis=1) >= 4))  # where the track first has four links
    mine = np.argmax(grid, axis=0)
    assert 0 < mine[0] < start < mine[4]
    np.testing.assert_array_equal(held_first[:, 0], np.arange(len(grid)) < start)  # held until four
    np.testing.assert_array_equal(held_first[:, 1:], own_first[:, 1:])  # the others: their own first
    rows = slice(mine[0] - window.start, start - window.start)
    assert (held[:, rows] > own[:, rows]).all()  # link 0 still kept off there
    np.testing.assert_array_equal(held[:, start - window.start :], own[:, start - window.start :])
    never, never_first = clearance(clearance_links=6)
    assert never_first.all() and (never >= held).all()


def test_surface_term_needs_the_distance_sensors(scene_for):
    """Without ``scene.link_distance_cutoff`` the scene has no distance sensors (the model is the
    default one), and a cost with a surface term refuses it, naming the option."""
    scene = scene_for("stapler")
    assert scene.index.link_object_dist.shape == (len(scene.index.link_bodies), 0)
    with_sensors = scene_for("stapler", "scene.link_distance_cutoff=0.05")
    assert with_sensors.plant_model.nsensor > scene.plant_model.nsensor
    ref = static_reference(scene)
    track = ReferenceTrack.build(
        ref, scene.task.layout, scene.task.time_scale, scene.planner_model.opt.timestep, 1.0
    )
    TrackingCost().bind(scene, track)  # no surface term: fine
    with pytest.raises(ValueError, match="scene.link_distance_cutoff"):
        TrackingCost(surface_weight=1.0).bind(scene, track)


@pytest.mark.parametrize("task", ["apple", "doorknob"])
def test_rest_term_is_the_objects_speed_after_the_last_expected_contact(scene_for, task):
    """The rest term against the object's velocity in MjData: the implicit-fast step moves a hinge, a slide
    or a free body's position by ``dt`` times its new velocity and turns a free body by ``dt |w|``, so the
    configuration's change between rollout steps over ``dt`` is the speed at the later step. It is priced
    only after the reference's last expected contact (0 before, and on the window's first row), weighted by
    ``lambda_o`` times ``rest_weight``; 0 (the default) leaves every other term as it was, bit for bit."""
    scene = scene_for(task)
    m = scene.planner_model
    ref = static_reference(scene, active_links=3)
    last = len(ref.time) // 2
    ref.contact_active[last + 1 :] = False  # the reference lets go halfway
    track = ReferenceTrack.build(ref, scene.task.layout, scene.task.time_scale, m.opt.timestep, 1.0)
    data = scene.make_data(m)
    idx = scene.index
    rng = np.random.default_rng(11)
    data.qvel[idx.object_dof] = rng.normal(0.0, 0.5, len(idx.object_dof))  # the object set moving
    x0 = np.empty(mujoco.mj_stateSize(m, mujoco.mjtState.mjSTATE_FULLPHYSICS))
    mujoco.mj_getState(m, data, x0, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    H = len(track.contact_active) - 1
    ctrl = scene.task.hand_home + rng.normal(0.0, 0.1, (2, H, m.nu))
    with RolloutEngine(m, nthread=1) as engine:
        state, sensordata, diverged = engine.run(x0, ctrl)
    assert not diverged.any()
    window = track.window(0.0, H)
    after = np.flatnonzero(~track.contact_active.any(axis=1))
    first_after = int(after[0]) - window.start
    assert 2 < first_after < H - 2

    cost = TrackingCost(lambda_o=2.0, rest_weight=3.0, rotation_weight=0.1, articulation_weight=0.5)
    cost.bind(scene, track)
    rest = cost.rest_term(sensordata, window)
    assert (rest[:, :first_after] == 0.0).all()
    layout = scene.task.layout
    for s in range(2):
        for h in range(first_after, H):  # sensordata row h is the state after h steps: state[h - 1]
            mujoco.mj_setState(m, data, state[s, h - 1], mujoco.mjtState.mjSTATE_FULLPHYSICS)
            v = data.qvel[idx.object_dof]
            if layout.free_columns:  # the apple: one free body, its linear then angular dofs
                assert layout.free_columns == (0,) and not layout.articulation_columns
                lin, ang, art = float(v[:3] @ v[:3]), float(v[3:6] @ v[3:6]), 0.0
            else:  # the doorknob: hinges, one dof per column
                lin, ang, art = 0.0, 0.0, float(v @ v)
            direct = lin + 0.1 * ang + 0.5 * art
            assert rest[s, h] == pytest.approx(direct, rel=1e-6, abs=1e-12)  # measured: 4e-13
    assert rest[:, first_after:].min() > 0.0
    terms = cost(sensordata, window)
    np.testing.assert_array_equal(terms["rest"], 2.0 * 3.0 * rest)

    off = TrackingCost(lambda_o=2.0, rotation_weight=0.1, articulation_weight=0.5)
    off.bind(scene, track)
    plain = off(sensordata, window)
    assert (plain["rest"] == 0.0).all()
    for name in TrackingCost.terms[:-1]:
        np.testing.assert_array_equal(plain[name], terms[name])


def test_lazy_distances_compute_only_the_distances_a_plan_reads_and_change_no_trial(scene_for):
    """``planner.lazy_distances``: a plan computes the link-object distances only of the links a term reads
    in its window (the clearance term's before their first expected contact; a link expected from the start
    never, a link never expected always); the trial logs the same, bit for bit (but the plans' wall time),
    and the engine's model keeps its distance sensors between plans; refused with a robust ensemble."""
    from contactmpc.control.planners import PredictiveSampling
    from contactmpc.control.robust import ModelEnsemble
    from contactmpc.control.samplers import PCASplineSpace
    from contactmpc.trial import Trial
    from contactmpc.validate import ConfigError

    # a 50 cm margin holds every read link inside it, so the term is met on any processor (at 5 cm whether
    # a link comes that near in 0.8 s is the trial's draw)
    scene = scene_for("stapler", "scene.link_distance_cutoff=0.5")
    ref = static_reference(scene, duration=0.6, active_links=21)
    n = len(ref.contact_active)
    ref.contact_active[:] = False
    ref.contact_active[:, 3:6] = True  # expected from the start: never read
    ref.contact_active[n // 2 :, 6:10] = True  # read until their first expected contact, halfway
    geomdist = mujoco.mjtSensor.mjSENS_GEOMDIST
    runs, unread = [], []
    for lazy in (False, True):
        planner = PredictiveSampling(num_samples=8, horizon=0.2, nthread=1, replan_period=0.05,
                                     lazy_distances=lazy)  # fmt: skip
        cost = TrackingCost(lambda_v=0.0, clearance_weight=100.0, clearance=0.5)
        trial = Trial(scene, ref, PCASplineSpace(0.2), cost, planner, 3, duration=0.8, progress=False)
        if lazy:
            real = planner._unread_distances

            def spy(window, real=real):
                ids = real(window)
                unread.append((window.start, ids.copy()))
                return ids

            planner._unread_distances = spy
        try:
            runs.append(trial.run().arrays())
        finally:
            planner.close()
    m, idx = scene.planner_model, scene.index
    assert (m.sensor_type[np.searchsorted(m.sensor_adr, idx.link_object_dist.ravel())] == geomdist).all()
    sensors = {link: set(np.searchsorted(m.sensor_adr, idx.link_object_dist[link])) for link in range(21)}
    first = int(np.argmin(cost._before_first[:, 7]))  # link 7's first expected contact, on the track
    assert unread and all(sensors[4] <= set(ids) for _, ids in unread)  # expected from the start
    assert all(not sensors[0] & set(ids) for _, ids in unread)  # never expected: always computed
    early = [ids for start, ids in unread if start < first]
    late = [ids for start, ids in unread if start >= first]
    assert early and late
    assert all(not sensors[7] & set(ids) for ids in early) and all(sensors[7] <= set(ids) for ids in late)
    assert runs[0]["cost_clearance"].max() > 0.0  # the term is met
    for key in runs[0]:
        if key != "plan_seconds":
            np.testing.assert_array_equal(runs[0][key], runs[1][key], err_msg=key)
    with pytest.raises(ConfigError, match="lazy_distances.*not with planner.guidance or planner.robust"):
        PredictiveSampling(num_samples=8, horizon=0.2, lazy_distances=True, robust=ModelEnsemble())
