"""Uniform clamped B-splines and the PCA of finger curves (PC-curves)."""

import numpy as np
import pytest
from scipy.interpolate import BSpline, PPoly

from contactmpc.reference import PCABasis, PCACurves, UniformBSpline


def _random_spline(rng: np.random.Generator) -> UniformBSpline:
    m = int(rng.integers(4, 25))
    t0 = float(rng.uniform(-2.0, 2.0))
    return UniformBSpline(m, (t0, t0 + float(rng.uniform(0.5, 10.0))))


def test_knots_are_clamped_and_uniform() -> None:
    spline = UniformBSpline(10, (1.0, 8.0))
    knots = spline.knots
    assert knots.shape == (10 + 3 + 1,)
    np.testing.assert_array_equal(knots[:4], 1.0)
    np.testing.assert_array_equal(knots[-4:], 8.0)
    np.testing.assert_allclose(np.diff(knots[3:-3]), spline.knot_spacing)
    assert spline.knot_spacing == pytest.approx(1.0)


def test_evaluate_matches_scipy_bspline_and_is_batched() -> None:
    rng = np.random.default_rng(0)
    for _ in range(20):
        spline = _random_spline(rng)
        t0, t1 = spline.domain
        cp = rng.normal(size=(spline.num_control_points, 3))
        times = np.concatenate([rng.uniform(t0, t1, 200), spline.knots, [t0, t1]])
        expected = BSpline(spline.knots, cp, 3)(times)
        np.testing.assert_allclose(spline.evaluate(cp, times), expected, atol=1e-12)
        # Batched over leading axes: (S, M, D) -> (S, N, D).
        batch = rng.normal(size=(5, 2, spline.num_control_points, 3))
        out = spline.evaluate(batch, times)
        assert out.shape == (5, 2, times.size, 3)
        np.testing.assert_allclose(out[3, 1], BSpline(spline.knots, batch[3, 1], 3)(times), atol=1e-12)
        # Partition of unity.
        np.testing.assert_allclose(spline.basis(times).sum(axis=1), 1.0, atol=1e-13)


def test_times_outside_domain_are_clipped() -> None:
    spline = UniformBSpline(8, (0.0, 2.0))
    cp = np.random.default_rng(1).normal(size=(8, 2))
    out = spline.evaluate(cp, np.array([-5.0, 0.0, 2.0, 7.0]))
    np.testing.assert_allclose(out[0], cp[0])
    np.testing.assert_allclose(out[1], cp[0])
    np.testing.assert_allclose(out[2], cp[-1])
    np.testing.assert_allclose(out[3], cp[-1])
    np.testing.assert_array_equal(spline.derivative_basis(np.array([-1.0, 3.0]), 1), 0.0)


def test_c2_continuity_at_interior_knots() -> None:
    rng = np.random.default_rng(2)
    spline = UniformBSpline(12, (0.0, 3.0))
    cp = rng.normal(size=(12, 4))
    interior = spline.knots[4:-4]
    jumps = []
    for dim in range(4):
        pp = PPoly.from_spline(BSpline(spline.knots, cp[:, dim], 3))
        for knot in interior:
            i = int(np.flatnonzero(pp.x == knot)[0])  # piece i starts at the knot, piece i-1 ends there
            h = pp.x[i] - pp.x[i - 1]
            for d in range(4):
                left = np.polyval(np.polyder(pp.c[:, i - 1], d), h)
                right = np.polyval(np.polyder(pp.c[:, i], d), 0.0)
                if d < 3:
                    assert left == pytest.approx(right, rel=1e-9, abs=1e-9), (knot, d, dim)
                else:
                    jumps.append(abs(left - right))
    assert max(jumps) > 1e-3  # the third derivative does jump: the check above is not vacuous
    # The derivative basis agrees with scipy's derivatives away from the knots.
    times = rng.uniform(0.0, 3.0, 100)
    for nu in (1, 2):
        expected = BSpline(spline.knots, cp, 3).derivative(nu)(times)
        np.testing.assert_allclose(spline.derivative_basis(times, nu) @ cp, expected, atol=1e-9)


def test_fit_recovers_control_points() -> None:
    rng = np.random.default_rng(3)
    for _ in range(10):
        spline = _random_spline(rng)
        t0, t1 = spline.domain
        cp = rng.normal(size=(spline.num_control_points, 5))
        times = np.linspace(t0, t1, 4 * spline.num_control_points + 7)
        values = spline.evaluate(cp, times)
        np.testing.assert_allclose(spline.fit(times, values), cp, atol=1e-9)
        np.testing.assert_allclose(spline.fit(times, values[:, 0]), cp[:, 0], atol=1e-9)
        np.testing.assert_allclose(spline.fit(times, values, smoothing=1e-12), cp, atol=1e-6)


def _nonzero_on_window(spline: UniformBSpline, a: float, b: float) -> np.ndarray:
    t0, t1 = spline.domain
    lo, hi = min(max(a, t0), t1), min(max(b, t0), t1)
    knots = spline.knots[(spline.knots >= lo) & (spline.knots <= hi)]
    samples = np.concatenate([np.linspace(lo, hi, 4001), knots, [lo, hi]])
    return np.flatnonzero(np.any(spline.basis(samples) != 0.0, axis=0))


def test_window_indices_equal_nonzero_basis_on_window() -> None:
    rng = np.random.default_rng(4)
    checked = 0
    for _ in range(40):
        m = int(rng.integers(4, 16))
        # Integer knots (h = 1) so that windows built from knots are exact in floating point.
        spline = UniformBSpline(m, (0.0, float(m - 3)))
        t1 = spline.domain[1]
        windows = [(float(rng.uniform(-1.0, t1 + 1.0)), float(rng.uniform(0.0, 3.0))) for _ in range(10)]
        spans = np.arange(0.0, t1 + 1.0)
        for _ in range(10):
            start = float(rng.choice(spans))
            windows.append((start, float(rng.integers(0, 4))))  # knot to knot, incl. zero length
            windows.append((start, float(rng.uniform(0.0, 2.5))))  # knot to anywhere
        windows += [(0.0, 0.0), (0.0, t1), (-3.0, 1.0), (t1, 0.0), (t1 - 0.5, 2.0), (t1 + 2.0, 1.0)]
        windows += [(-5.0, 5.0 + t1), (-1.0, 1.0), (-1.0, 0.5)]
        for t, horizon in windows:
            got = spline.window_indices(t, horizon)
            expected = _nonzero_on_window(spline, t, t + horizon)
            np.testing.assert_array_equal(got, expected, err_msg=f"M={m} window=({t}, {horizon})")
            assert got.dtype == np.int64
            checked += 1
    assert checked > 1000


def test_window_indices_random_domains_and_support() -> None:
    rng = np.random.default_rng(5)
    for _ in range(30):
        spline = _random_spline(rng)
        t0, t1 = spline.domain
        for _ in range(10):
            t = float(rng.uniform(t0 - 0.5, t1 + 0.5))
            horizon = float(rng.uniform(0.0, (t1 - t0) / 2))
            got = spline.window_indices(t, horizon)
            np.testing.assert_array_equal(got, _nonzero_on_window(spline, t, t + horizon))
            for j in got:
                start, end = spline.support(int(j))
                assert start <= max(min(t + horizon, t1), t0) and end >= max(min(t, t1), t0)
    # A cubic interior window of one knot span touches exactly 4 control points (paper §II-C).
    spline = UniformBSpline(20, (0.0, 17.0))
    np.testing.assert_array_equal(spline.window_indices(5.0, 1.0), [5, 6, 7, 8])


def _finger_curves(rng: np.random.Generator, n: int = 400, dim: int = 16) -> tuple[np.ndarray, np.ndarray]:
    times = np.linspace(0.0, 4.0, n)
    latent = np.stack([np.sin(times), np.cos(2 * times), times**2 / 16, np.sin(3 * times + 1)], axis=1)
    mixing = rng.normal(size=(4, dim))
    curves = latent @ mixing + 0.01 * rng.normal(size=(n, dim)) + rng.normal(size=dim)
    return times, curves


def test_pca_reconstruction_and_orthonormality() -> None:
    rng = np.random.default_rng(6)
    _, curves = _finger_curves(rng)
    for whiten in (False, True):
        pca = PCABasis.fit(curves, whiten=whiten)
        assert pca.num_components == 16 and pca.components.shape == (16, 16)
        np.testing.assert_allclose(pca.components @ pca.components.T, np.eye(16), atol=1e-12)
        assert np.all(np.diff(pca.variance) <= 1e-12)
        np.testing.assert_allclose(pca.from_pc(pca.to_pc(curves)), curves, atol=1e-9)
        z = pca.to_pc(curves)
        np.testing.assert_allclose(z.mean(axis=0), 0.0, atol=1e-9)
        if whiten:
            np.testing.assert_allclose(z.std(axis=0), 1.0, rtol=1e-9)
        else:
            np.testing.assert_allclose(z.std(axis=0), pca.spread, rtol=1e-9)
        # Batched over leading axes.
        batch = rng.normal(size=(3, 7, 16))
        assert pca.from_pc(batch).shape == (3, 7, 16)
        np.testing.assert_allclose(pca.from_pc(batch)[2, 5], pca.from_pc(batch[2, 5]))
    # Sign convention: the largest-magnitude entry of each component is positive; reproducible.
    pca = PCABasis.fit(curves)
    rows = np.arange(16)
    assert np.all(pca.components[rows, np.argmax(np.abs(pca.components), axis=1)] > 0)
    np.testing.assert_array_equal(PCABasis.fit(curves.copy()).components, pca.components)
    # Truncation keeps the leading components.
    np.testing.assert_allclose(PCABasis.fit(curves, num_components=4).components, pca.components[:4])


def test_pca_degenerate_components() -> None:
    rng = np.random.default_rng(7)
    _, curves = _finger_curves(rng, n=50)
    curves[:, 3] = 0.7  # a joint that never moves
    curves = curves[:10]  # fewer samples than joints: rank <= 9
    pca = PCABasis.fit(curves, whiten=True, min_spread=1e-6)
    np.testing.assert_allclose(pca.components @ pca.components.T, np.eye(16), atol=1e-12)
    assert np.all(pca.spread >= 1e-6) and np.all(np.isfinite(pca.spread))
    np.testing.assert_allclose(pca.from_pc(pca.to_pc(curves)), curves, atol=1e-9)
    z = pca.to_pc(curves)
    live = pca.variance > 1e-12
    assert live.sum() == 9
    np.testing.assert_allclose(z[:, live].std(axis=0), 1.0, rtol=1e-9)
    # Noise on a dead component barely moves the joints (the spread floor).
    dead = np.flatnonzero(~live)[0]
    bump = np.zeros(16)
    bump[dead] = 1.0
    assert np.abs(pca.from_pc(bump) - pca.mean).max() <= 1e-6 + 1e-15


@pytest.mark.parametrize("whiten", [False, True])
def test_pc_control_points_map_exactly_to_joint_control_points(whiten: bool) -> None:
    rng = np.random.default_rng(8)
    times, curves = _finger_curves(rng)
    spline = UniformBSpline(14, (0.0, 4.0))
    pcc = PCACurves.fit(spline, times, curves, whiten=whiten)
    assert pcc.pc_control_points.shape == (14, 16)
    direct = spline.fit(times, curves)
    np.testing.assert_allclose(pcc.joint_control_points(), direct, atol=1e-9)
    np.testing.assert_allclose(pcc.joint_curves(times), spline.evaluate(direct, times), atol=1e-9)
    np.testing.assert_allclose(pcc.pca.to_pc(direct), pcc.pc_control_points, atol=1e-9)
    # The PC-curves are the spline fit of the PC coordinates of the data.
    np.testing.assert_allclose(
        pcc.pc_curves(times), spline.evaluate(spline.fit(times, pcc.pca.to_pc(curves)), times), atol=1e-9
    )
    # Batched perturbations: joint curves of perturbed PC control points == spline of mapped points.
    noisy = pcc.pc_control_points + 0.3 * rng.normal(size=(6, 14, 16))
    joint_cp = pcc.joint_control_points(noisy)
    assert joint_cp.shape == (6, 14, 16)
    np.testing.assert_allclose(
        pcc.joint_curves(times, noisy), pcc.pca.from_pc(spline.evaluate(noisy, times)), atol=1e-9
    )


def test_greville_abscissae_run_from_the_domain_start_to_its_end_in_order():
    """The Greville abscissa of a clamped spline's first control point is the domain's start, of its last
    the end, increasing between, each the mean of its degree inner knots."""
    spline = UniformBSpline(12, (0.0, 10.0))
    g = spline.greville(np.arange(12))
    assert g[0] == 0.0 and g[-1] == 10.0 and np.all(np.diff(g) > 0)
    np.testing.assert_allclose(g[5], spline.knots[6:9].mean())
