"""The window stage's maths on exact cases: three-view length ratios, the joint solve of a window's step
lengths (noise-free measurements give the true motions back; gross outliers are down-weighted), and its
latency, standstill and gap rules."""

import numpy as np
import pytest

from flowvo.geometry import invert_se3, so3_exp
from flowvo.odometry.scale_propagation import step_length_ratio
from flowvo.odometry.scale_window import (
    CONVERGED_LOG,
    ROAD_SIGMA,
    ScaleWindow,
    StepScale,
    carried_prior,
    log_length_sigmas,
    robust_log_lengths,
)
from flowvo.odometry.scale_window_scipy import scipy_log_lengths
from flowvo.odometry.two_view import EssentialMotion, se3_next_prev

K = np.array([[359.0, 0.0, 303.0], [0.0, 359.0, 92.0], [0.0, 0.0, 1.0]])


def project(points):
    pixels = points @ K.T
    return pixels[:, :2] / pixels[:, 2:]


def step(yaw_rad, length_m):
    """A forward step while turning: (R_next_prev, unit t, T_next_prev)."""
    R = so3_exp(np.array([0.0, yaw_rad, 0.0]))
    t = -R @ np.array([0.02, 0.0, 1.0]) / np.linalg.norm([0.02, 0.0, 1.0])
    return R, t, se3_next_prev(R, t * length_m)


def three_views(seed, count):
    """``count`` scene points seen from three cameras a -> b -> c (steps of 0.8 and 1.1 m while turning): the
    pixels (a, b, c) and the two steps' motions."""
    rng = np.random.default_rng(seed)
    scene_a = np.c_[rng.uniform(-10, 10, count), rng.uniform(-3, 1.5, count), rng.uniform(6, 40, count)]
    R1, t1, T_ba = step(0.02, 0.8)
    R2, t2, T_cb = step(-0.03, 1.1)
    to_b = scene_a @ T_ba[:3, :3].T + T_ba[:3, 3]
    everyone = np.ones(count, bool)
    pixels = project(scene_a), project(to_b), project(to_b @ T_cb[:3, :3].T + T_cb[:3, 3])
    return pixels, EssentialMotion(R1, t1, everyone), EssentialMotion(R2, t2, everyone)


def test_three_views_give_the_exact_ratio_of_the_step_lengths():
    (a, b, c), first, second = three_views(3, 200)
    ratio = step_length_ratio((a, b), first, (b, c), second, K)
    assert ratio.ratio == pytest.approx(1.1 / 0.8, rel=1e-9)
    assert ratio.log_sigma < 1e-9  # every point gives the same ratio


def test_the_ratio_of_noisy_tracks_comes_with_its_standard_error():
    """Tracks with 0.3 px of noise: the ratio is off by about its standard error, which grows with the noise."""
    pixels, first, second = three_views(5, 300)
    rng = np.random.default_rng(5)

    def measured(noise_px):
        a, b, c = (p + rng.normal(0.0, noise_px, p.shape) for p in pixels)
        return step_length_ratio((a, b), first, (b, c), second, K)

    slight, strong = measured(0.1), measured(0.3)
    assert 0.0 < slight.log_sigma < strong.log_sigma < 0.05
    assert abs(np.log(strong.ratio / (1.1 / 0.8))) < 3.0 * strong.log_sigma


def test_three_views_without_parallax_give_no_ratio():
    rng = np.random.default_rng(3)
    far = np.c_[rng.uniform(-10, 10, 100), rng.uniform(-3, 1.5, 100), np.full(100, 1e5)]  # no depth to see
    R, t, T = step(0.0, 1.0)
    a, b = project(far), project(far @ T[:3, :3].T + T[:3, 3])
    motion = EssentialMotion(R, t, np.ones(100, bool))
    assert step_length_ratio((a, b), motion, (b, b), motion, K) is None


def drive(lengths_m, road_every=1, yaw_rad=0.01):
    """StepScale of each step of a drive with exact ratios, and road lengths on every ``road_every``-th
    step; with the true motions T_prev_cur."""
    steps, truths = [], []
    for k, length in enumerate(lengths_m):
        R, t, T_next_prev = step(yaw_rad, length)
        ratio = None if k == 0 else length / lengths_m[k - 1]
        road = length if k % road_every == 0 else None
        steps.append(StepScale(R, t, pair_m=length, dt_s=0.1, road_m=road, ratio=ratio))
        truths.append(invert_se3(T_next_prev))
    return steps, truths


def run_window(steps, window=None):
    window = window or ScaleWindow()
    emitted = []
    for k, s in enumerate(steps):
        emitted += window.push(0.1 * (k + 1), s)
    return emitted + window.flush()


def test_noise_free_measurements_give_the_true_motions_back():
    lengths = np.linspace(0.3, 1.4, 40) ** 1.5  # accelerating from 0.16 to 1.66 m a step
    steps, truths = drive(lengths, road_every=4)  # the road on every fourth step only: ratios carry the rest
    emitted = run_window(steps)
    assert [t for t, _ in emitted] == pytest.approx([0.1 * (k + 1) for k in range(40)])
    for (_, motion), truth in zip(emitted, truths, strict=True):
        np.testing.assert_allclose(motion, truth, atol=1e-6)


def test_gross_road_outliers_are_down_weighted():
    lengths = np.full(40, 1.0)
    steps, _ = drive(lengths)
    for k in (10, 11, 25):  # a road reading 60 % long, twice in a row, and one 40 % short
        steps[k] = StepScale(steps[k].R, steps[k].t_dir, 1.0, 0.1, road_m=0.6 if k == 25 else 1.6,
                             ratio=steps[k].ratio)
    robust = np.array([np.linalg.norm(m[:3, 3]) for _, m in run_window(steps)])
    links = [(k, 0.0, 0.01) for k in range(1, 20)]
    roads = [(k, float(np.log(1.6 if k in (10, 11) else 1.0)), ROAD_SIGMA) for k in range(20)]
    plain = np.exp(np.linalg.lstsq(*_normal_system(links, roads, 20), rcond=None)[0])
    assert np.abs(robust - 1.0).max() < 0.008  # Cauchy: a 9-sigma outlier keeps 5 % of its weight
    assert np.abs(plain - 1.0).max() > 0.04  # least squares: the two outliers move every step by 5 %


def _normal_system(links, absolutes, count):
    A, b = [], []
    for k, value, sigma in links:
        row = np.zeros(count)
        row[k], row[k - 1] = 1.0 / sigma, -1.0 / sigma
        A.append(row)
        b.append(value / sigma)
    for k, value, sigma in absolutes:
        row = np.zeros(count)
        row[k] = 1.0 / sigma
        A.append(row)
        b.append(value / sigma)
    return np.array(A), np.array(b)


def test_a_window_without_any_measurement_leaves_its_steps_undetermined():
    np.testing.assert_allclose(robust_log_lengths([], [], 3), 0.0)
    R, t, _ = step(0.0, 1.0)
    unmeasured = [StepScale(R, t, 0.0, 0.1) for _ in range(3)]  # not even a per-pair length
    assert [np.linalg.norm(m[:3, 3]) for _, m in run_window(unmeasured)] == [0.0, 0.0, 0.0]


def test_robust_solve_of_consistent_measurements_is_exact():
    truth = np.log(np.array([0.5, 0.6, 0.8, 0.7, 0.9]))
    links = [(k, truth[k] - truth[k - 1], 0.01) for k in range(1, 5)]
    np.testing.assert_allclose(robust_log_lengths(links, [(2, truth[2], 0.05)], 5), truth, atol=1e-12)


def test_each_motion_is_final_latency_frames_late_and_a_standstill_flushes():
    steps, _ = drive(np.full(12, 1.0))
    window = ScaleWindow(latency_frames=3)
    counts = [len(window.push(0.1 * (k + 1), s)) for k, s in enumerate(steps[:6])]
    assert counts == [0, 0, 0, 1, 1, 1]
    stopped = window.push(0.7, None)  # a standstill: the three pending motions, then the identity
    assert [t for t, _ in stopped] == pytest.approx([0.4, 0.5, 0.6, 0.7])
    np.testing.assert_array_equal(stopped[-1][1], np.eye(4))
    assert [len(window.push(0.8 + 0.1 * k, s)) for k, s in enumerate(steps[6:])] == [0, 0, 0, 1, 1, 1]
    assert len(window.flush()) == 3


def test_without_latency_every_motion_comes_back_at_once():
    steps, truths = drive(np.array([0.5, 0.6, 0.7]))
    window = ScaleWindow(latency_frames=0)
    for k, (s, truth) in enumerate(zip(steps, truths, strict=True)):
        (time_s, motion), = window.push(0.1 * (k + 1), s)
        np.testing.assert_allclose(motion, truth, atol=1e-9)
    assert window.flush() == []


def test_measurements_that_are_not_positive_finite_lengths_are_ignored():
    steps, truths = drive(np.full(8, 0.9))
    broken = [StepScale(s.R, s.t_dir, s.pair_m, s.dt_s, road_m=bad, network_m=bad, ratio=s.ratio)
              for s, bad in zip(steps, [None, np.inf, np.nan, -1.0, 0.0, 0.9, np.inf, 0.9], strict=True)]
    for (_, motion), truth in zip(run_window(broken), truths, strict=True):
        np.testing.assert_allclose(motion, truth, atol=1e-6)


def test_steps_without_a_ratio_keep_the_speed_across_a_dropped_frame():
    steps, _ = drive(np.full(12, 1.0))
    steps = [StepScale(s.R, s.t_dir, 0.0, s.dt_s, road_m=1.0 if k < 6 else None, ratio=None)
             for k, s in enumerate(steps)]
    steps[8] = StepScale(steps[8].R, steps[8].t_dir, 0.0, 0.2)  # a frame dropped: twice the time, no road
    lengths = [np.linalg.norm(m[:3, 3]) for _, m in run_window(steps)]
    np.testing.assert_allclose(lengths, [1.0] * 8 + [2.0] + [1.0] * 3, rtol=1e-9)


def test_a_long_gap_without_a_ratio_breaks_the_link():
    """Steps after an hour's gap keep their own road length, not the speed before it."""
    before, _ = drive(np.full(10, 1.0))
    after, _ = drive(np.full(10, 0.2))
    gap = after[0]
    after[0] = StepScale(gap.R, gap.t_dir, gap.pair_m, 3600.0, road_m=0.2, ratio=None)
    lengths = [np.linalg.norm(m[:3, 3]) for _, m in run_window(before + after)]
    np.testing.assert_allclose(lengths, [1.0] * 10 + [0.2] * 10, rtol=1e-9)


def test_the_robust_solve_is_the_minimum_scipy_finds_under_the_cauchy_loss():
    """Cross-check against a well-kept solver: scipy's least_squares with the Cauchy loss, started where
    the iterations end, stays there (the iterations reached a minimum of the same cost)."""
    from scipy.optimize import least_squares

    rng = np.random.default_rng(7)
    truth = np.cumsum(rng.normal(0.0, 0.02, 25))
    links = [(k, truth[k] - truth[k - 1] + rng.normal(0.0, 0.01), 0.01) for k in range(1, 25)]
    absolutes = [(k, truth[k] + rng.normal(0.0, 0.05) + (0.5 if k in (4, 17) else 0.0), 0.05) for k in range(25)]
    solved = robust_log_lengths(links, absolutes, 25)
    A, b = _normal_system(links, absolutes, 25)
    reference = least_squares(lambda x: A @ x - b, solved, loss="cauchy", f_scale=2.0, xtol=1e-14, ftol=1e-14,
                              gtol=1e-14).x
    np.testing.assert_allclose(solved, reference, atol=CONVERGED_LOG)  # where the iterations stop
    clean = [(k, value - (0.5 if k in (4, 17) else 0.0), sigma) for k, value, sigma in absolutes]
    np.testing.assert_allclose(solved, robust_log_lengths(links, clean, 25), atol=0.01)  # the outliers left out


def test_scipy_solves_the_same_window_with_sums_and_outliers_alike():
    """The window's own iterations against SciPy's least_squares on ratios, roads with two gross outliers and
    roads over several steps: the same lengths, to the iterations' stopping rule."""
    rng = np.random.default_rng(11)
    truth = np.cumsum(rng.normal(0.0, 0.03, 20))
    links = [(k, truth[k] - truth[k - 1] + rng.normal(0.0, 0.01), 0.01) for k in range(1, 20) if k != 9]
    absolutes = [(k, truth[k] + rng.normal(0.0, 0.05) + (0.6 if k in (4, 14) else 0.0), 0.05) for k in range(0, 20, 2)]
    sums = [(first, first + 2, float(np.log(np.exp(truth[first:first + 3]).sum())) + rng.normal(0.0, 0.05), 0.05)
            for first in (5, 11, 16)]
    ours, scipy = (solve(links, absolutes, 20, sums=sums) for solve in (robust_log_lengths, scipy_log_lengths))
    np.testing.assert_allclose(ours, scipy, atol=3 * CONVERGED_LOG)
    assert np.abs(ours - truth).max() < 0.05  # the outliers (0.6 in log: 82 % long) left out


def test_a_step_leaving_the_window_passes_on_what_was_measured_of_it():
    """The prior on the next step: the step's measurements fused by their inverse variances, shifted by the
    link's log ratio, with the link's variance added."""
    mean, sigma = carried_prior([(np.log(2.0), 0.1), (np.log(2.0) + 0.3, 0.2)], (np.log(1.5), 0.05))
    assert mean == pytest.approx(np.log(2.0) + 0.3 * 0.01 / (0.01 + 0.04) + np.log(1.5), abs=1e-12)
    assert sigma == pytest.approx(np.sqrt(1.0 / (1.0 / 0.01 + 1.0 / 0.04) + 0.05**2), abs=1e-12)
    assert carried_prior([], (0.0, 0.01)) is None  # nothing measured of the step
    assert carried_prior([(0.0, 0.1)], None) is None  # no link to the next step


def test_the_road_sets_the_scale_long_after_it_was_last_seen():
    """Exact ratios carry the road's scale through 10 s without road, far beyond the 2 s window, where the
    per-pair estimate knows nothing: every motion comes back exact (a window that forgot the road had
    nothing left to scale its steps with)."""
    lengths = 1.5 * 0.99 ** np.arange(100)  # slowing down by 1 % a step
    steps, truths = drive(lengths, road_every=1000)  # the road on the first step only
    steps = [StepScale(s.R, s.t_dir, 0.0, s.dt_s, s.road_m, ratio=s.ratio) for s in steps]  # no per-pair length
    for (_, motion), truth in zip(run_window(steps), truths, strict=True):
        np.testing.assert_allclose(motion, truth, atol=1e-6)


def test_a_standstill_ends_what_the_window_carries():
    """After a stop the first road sets the scale: nothing of the speed before the stop is carried on."""
    before, _ = drive(np.full(30, 1.0))
    after, truths = drive(np.full(30, 0.4), road_every=1000)
    lengths = [np.linalg.norm(m[:3, 3]) for _, m in run_window(before + [None] + after)]
    np.testing.assert_allclose(lengths[31:], 0.4, rtol=1e-6)


def test_an_uncertain_ratio_counts_less():
    """Ratios that all run 3 % long against roads that say constant speed: with a large standard error
    the ratios give way to the roads, with none they pull the lengths off."""
    lengths = np.full(40, 1.0)
    steps, _ = drive(lengths)

    def deviation(log_sigma: float) -> float:
        biased = [StepScale(s.R, s.t_dir, 1.0, 0.1, road_m=s.road_m, ratio=None if k == 0 else 1.03,
                            ratio_log_sigma=log_sigma) for k, s in enumerate(steps)]
        return float(np.abs([np.linalg.norm(m[:3, 3]) - 1.0 for _, m in run_window(biased)]).max())

    assert deviation(0.0) > 0.05
    assert deviation(0.1) < 0.02


def test_a_sum_of_lengths_is_solved_exactly():
    """A road measured from a key frame three steps back is a measurement of the three steps' summed length."""
    truth = np.log(np.array([0.5, 0.45, 0.4, 0.3, 0.25]))
    links = [(k, truth[k] - truth[k - 1], 0.01) for k in (1, 2, 4)]  # no ratio between steps 2 and 3
    sums = [(2, 4, float(np.log(np.exp(truth[2:]).sum())), 0.05)]
    solved = robust_log_lengths(links, [(0, truth[0], 0.05)], 5, sums=sums)
    np.testing.assert_allclose(solved, truth, atol=1e-9)


def test_a_stop_measured_from_key_frames_keeps_each_step_its_length():
    """Stopping at 10 % less a step, the road measured from key frames up to three steps back and no ratios
    (too little parallax): solved as sums, the median step keeps its length within 1 % (steps measured as
    equal shares of each key frame's road ran 6 % long, median, up to 12 % in each key frame's last step)."""
    lengths = 0.5 * 0.9 ** np.arange(15)
    spans = [1 + k % 3 for k in range(15)]
    roads = [float(lengths[k + 1 - n : k + 1].sum()) for k, n in enumerate(spans)]
    steps, _ = drive(lengths)

    def solved(as_sums: bool) -> np.ndarray:
        stopping = [StepScale(s.R, s.t_dir, road / n, 0.1, road_m=road if as_sums else road / n,
                              road_steps=n if as_sums else 1) for s, road, n in zip(steps, roads, spans, strict=True)]
        return np.array([np.linalg.norm(m[:3, 3]) for _, m in run_window(stopping)]) / lengths - 1.0

    assert np.median(np.abs(solved(as_sums=True))) < 0.01
    assert np.median(np.abs(solved(as_sums=False))) > 0.05


def test_without_marginalisation_the_window_forgets_the_road():
    """The ablation's window: 10 s after the only road, with no per-pair length, the steps are left unscaled."""
    lengths = np.full(100, 1.0)
    steps, _ = drive(lengths, road_every=1000)
    steps = [StepScale(s.R, s.t_dir, 0.0, s.dt_s, s.road_m, ratio=s.ratio) for s in steps]
    found = [np.linalg.norm(m[:3, 3]) for _, m in run_window(steps, ScaleWindow(marginalise=False))]
    assert found[0] == pytest.approx(1.0) and found[-1] == pytest.approx(0.0, abs=1e-9)


def test_a_chain_of_consistent_measurements_has_the_sigmas_of_its_links():
    """One road (sigma 0.05) on the first step and exact ratios (0.01 each) down the chain: step k's log
    length has the variance of the road plus k links, as for a random walk from the road."""
    truth = np.log(np.array([1.0, 1.1, 0.9, 1.2]))
    links = [(k, truth[k] - truth[k - 1], 0.01) for k in range(1, 4)]
    sigmas = log_length_sigmas(links, [(0, truth[0], 0.05)], 4, robust_log_lengths(links, [(0, truth[0], 0.05)], 4))
    np.testing.assert_allclose(sigmas, np.sqrt(0.05**2 + np.arange(4) * 0.01**2), rtol=1e-6)


def test_an_outlier_adds_almost_no_certainty_and_a_conflict_removes_it():
    """Roads on a lone step (sigma 0.05 each): four agreeing give 0.05 / 2; three agreeing and one 20 sigmas
    off, whose Cauchy weight falls to 1 %, give the three's sigma; two that disagree by 20 sigmas leave
    the step less certain than either alone."""
    agreeing = [(0, 0.0, 0.05)] * 4
    outlier = [(0, 0.0, 0.05)] * 3 + [(0, 1.0, 0.05)]
    conflict = [(0, 0.0, 0.05), (0, 1.0, 0.05)]
    sigma = {name: log_length_sigmas([], absolutes, 1, robust_log_lengths([], absolutes, 1))[0]
             for name, absolutes in (("agreeing", agreeing), ("outlier", outlier), ("conflict", conflict))}
    assert sigma["agreeing"] == pytest.approx(0.025, rel=1e-6)
    assert sigma["outlier"] == pytest.approx(0.05 / np.sqrt(3.01), rel=1e-3)
    assert sigma["conflict"] > 0.15


def test_every_final_step_is_recorded_with_what_measured_it():
    """Roads every fourth step, ratios on all but the first, a standstill, then steps that only the per-pair
    estimate measures: one record per step in order; the held speed's sigma says it is a guess."""
    steps, _ = drive(np.full(8, 1.0), road_every=4)
    unmeasured = [StepScale(s.R, s.t_dir, 0.7, 0.1) for s in steps[:2]]
    window = ScaleWindow()
    for k, s in enumerate(steps + [None] + unmeasured):
        window.push(0.1 * (k + 1), s)
    window.flush()
    records = window.records
    assert [r.time_s for r in records] == pytest.approx([0.1 * (k + 1) for k in range(11)])
    assert [r.measured_by for r in records] == ["road", "ratio", "ratio", "ratio", "road+ratio", "ratio", "ratio",
                                                "ratio", "standstill", "none", "none"]
    assert [r.length_m for r in records[:8]] == pytest.approx(np.ones(8), abs=1e-6)
    assert records[8].length_m == 0.0 and records[8].log_sigma is None
    assert all(0.0 < r.log_sigma < ROAD_SIGMA for r in records[:8])
    assert [r.length_m for r in records[9:]] == pytest.approx([0.7, 0.7], abs=1e-6)
    assert all(r.log_sigma > 1.0 for r in records[9:])
    assert [r.unscaled for r in records] == [False] * 9 + [True, True]  # a standstill needs no scale


def test_a_turning_steps_ratio_counts_less():
    """Ratios that all run 1.5 % long against roads that say constant speed: where the steps turn 3.4 degrees
    each, ratios err more (RATIO_SIGMA_PER_DEG), and the window follows the roads more than on a straight."""
    def deviation(yaw_rad: float) -> float:
        steps, _ = drive(np.full(40, 1.0), yaw_rad=yaw_rad)
        biased = [StepScale(s.R, s.t_dir, 1.0, 0.1, road_m=s.road_m, ratio=None if k == 0 else 1.015)
                  for k, s in enumerate(steps)]
        return float(np.abs([np.linalg.norm(m[:3, 3]) - 1.0 for _, m in run_window(biased)]).max())

    assert deviation(np.radians(3.4)) < 0.5 * deviation(0.0)


def test_a_drive_that_starts_unmeasured_holds_its_steps_until_the_road_measures_them():
    """Steps of 1.2 m whose ratios are known but that nothing measures for 1 s (a fast start before the first
    trusted road; the per-pair estimate has no speed yet: 0 m): nothing is final until the road's first length,
    then every held step gets 1.2 m through the ratios, labelled by what measured it."""
    R, t, _ = step(0.0, 1.0)
    window = ScaleWindow(latency_frames=2)
    emitted = []
    for k in range(1, 16):
        road = 1.2 if k >= 11 else None
        emitted += window.push(k * 0.1, StepScale(R, t, 0.0, 0.1, road_m=road, ratio=1.0 if k > 1 else None))
        if k < 11:
            assert not emitted  # held: none of them is measured yet
    emitted += window.flush()
    lengths = [np.linalg.norm(motion[:3, 3]) for _, motion in emitted]
    np.testing.assert_allclose(lengths, 1.2, rtol=1e-6)
    assert [record.measured_by for record in window.records[:2]] == ["none", "ratio"]


def test_steps_nothing_ever_measures_are_given_out_after_the_hold_labelled_unmeasured():
    """Steps with ratios but no road, network or speed for 5 s: held at most 3 s, then given out with the
    per-pair length (0 m) and labelled "none", never as measured by their ratios."""
    R, t, _ = step(0.0, 1.0)
    window = ScaleWindow(latency_frames=2)
    emitted = [window.push(k * 0.1, StepScale(R, t, 0.0, 0.1, ratio=1.0)) for k in range(1, 51)]
    first_final = next(k for k, final in enumerate(emitted, start=1) if final)
    assert first_final == 31  # the first pending step ended at 0.1 s, held until 3.1 s
    assert {record.measured_by for record in window.records} == {"none"}
    assert all(record.length_m == 0.0 and record.log_sigma is None for record in window.records)


def test_a_mounting_in_doubt_holds_the_steps_and_a_mounting_taken_forgets_the_roads_before_it():
    """A camera whose mounting the drive finds for itself (rolled, not told): its first road, trusted through the
    wrong mounting, reads 0.5 m; the next planes are refused (the mounting in doubt) while the ratios measure a
    steady 1.0 m; then the drive takes its mounting and every road reads 1.0 m. Nothing is final while the mounting
    is in doubt, and every step comes out 1.0 m: the first road is forgotten, not averaged in."""
    R, t, _ = step(0.0, 1.0)

    def run(mounting_known):
        window = ScaleWindow(latency_frames=2)
        emitted = []
        for k in range(1, 31):
            pending, taken = 3 <= k < 15, k == 15
            road = 0.5 if k == 2 else 1.0 if k >= 15 else None
            scale = StepScale(R, t, 0.0, 0.1, road_m=road, ratio=1.0 if k > 2 else None,
                              mounting_pending=pending and mounting_known, mounting_taken=taken and mounting_known)
            final = window.push(k * 0.1, scale)
            if mounting_known and 3 <= k < 15:
                assert not final  # held while the mounting is in doubt
            emitted += final
        return np.array([np.linalg.norm(motion[:3, 3]) for _, motion in emitted + window.flush()])

    np.testing.assert_allclose(run(mounting_known=True)[1:], 1.0, rtol=1e-6)
    assert run(mounting_known=False)[1:13].max() < 0.9  # without the flags the wrong first road scales them


def test_a_mounting_in_doubt_that_the_drive_keeps_holds_the_steps_but_keeps_the_roads():
    """Planes refused for a while on a camera mounted as told (a banked ramp): the steps are held while the
    mounting is in doubt, then measured by the roads before and after alike, since no mounting was taken."""
    R, t, _ = step(0.0, 1.0)
    window = ScaleWindow(latency_frames=2)
    emitted = []
    for k in range(1, 31):
        road = 0.8 if k < 8 or k >= 14 else None
        final = window.push(k * 0.1, StepScale(R, t, 0.0, 0.1, road_m=road, ratio=1.0 if k > 1 else None,
                                               mounting_pending=8 <= k < 14))
        if 8 <= k < 14:
            assert not final
        emitted += final
    np.testing.assert_allclose([np.linalg.norm(m[:3, 3]) for _, m in emitted + window.flush()], 0.8, rtol=1e-6)


def test_without_latency_nothing_is_held():
    """``--latency 0`` gives every pose at once, as its help says: neither an unmeasured start nor a mounting in doubt
    holds a step back (they come out with their per-pair length)."""
    R, t, _ = step(0.0, 1.0)
    window = ScaleWindow(latency_frames=0)
    for k in range(1, 8):
        scale = StepScale(R, t, 0.9, 0.1, ratio=1.0 if k > 1 else None, mounting_pending=k > 3)
        (_, motion), = window.push(k * 0.1, scale)
        assert np.linalg.norm(motion[:3, 3]) == pytest.approx(0.9)
