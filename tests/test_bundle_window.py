"""The bundle stage of flowvo-ba (flowvo.odometry.bundle_window) and its tracks over many frames
(flowvo.odometry.landmark_tracks)."""

import cv2
import numpy as np
import pytest

from flowvo.geometry import invert_se3, relative_motions, rotation_angle_between_rad, so3_exp
from flowvo.odometry.bundle_window import BundleSettings, BundleWindow
from flowvo.odometry.landmark_tracks import LandmarkTracker

K = np.array([[700.0, 0.0, 310.0], [0.0, 700.0, 94.0], [0.0, 0.0, 1.0]])


def _drive(frames: int, points: int = 150, seed: int = 0):
    """True poses of a car turning 1.1 degrees a 1 m step, and every frame's exact view of points ahead of it
    (ids, px) (each point is seen from the frame it enters the window until it falls behind)."""
    rng = np.random.default_rng(seed)
    T = np.stack([np.eye(4)] * frames)
    for i in range(frames):
        T[i, :3, :3] = so3_exp(np.array([0.0, 0.02, 0.0]) * i)
        T[i, :3, 3] = np.array([0.02 * i * i / 2, 0.0, 1.0 * i])
    world = np.column_stack([rng.uniform(-20, 20, points), rng.uniform(-3, 1.6, points),
                             rng.uniform(10, 60 + frames, points)])
    views = []
    for pose in T:
        in_camera = world @ invert_se3(pose)[:3, :3].T + invert_se3(pose)[:3, 3]
        projected = in_camera @ K.T
        px = projected[:, :2] / projected[:, 2:3]
        seen = (in_camera[:, 2] > 2.0) & (np.abs(px[:, 0] - 310) < 300) & (np.abs(px[:, 1] - 94) < 90)
        views.append((np.flatnonzero(seen).astype(np.int64), px[seen]))
    return T, views, rng


def test_with_its_own_rotations_the_stage_takes_the_rotations_the_tracks_give_and_keeps_the_lengths():
    T, views, rng = _drive(16)
    true_motions = relative_motions(T)
    given = true_motions.copy()
    for motion in given:  # each step's rotation 0.05 degrees off, its length true
        motion[:3, :3] = so3_exp(rng.normal(0.0, np.radians(0.05) / np.sqrt(3), 3)) @ motion[:3, :3]
    stage = BundleWindow(K, BundleSettings(frames=6, own_rotations=True))
    final = stage.push(0.0, None, *views[0])
    for i, motion in enumerate(given, start=1):
        final += stage.push(0.1 * i, motion, *views[i], 0.01)
        assert len(final) == max(i - stage.latency_frames, 0)  # each motion 5 frames late
    final += stage.flush()
    assert [time_s for time_s, _ in final] == pytest.approx([0.1 * i for i in range(1, 16)])
    refined = np.stack([motion for _, motion in final])
    before = rotation_angle_between_rad(given[:, :3, :3], true_motions[:, :3, :3])
    after = rotation_angle_between_rad(refined[:, :3, :3], true_motions[:, :3, :3])
    assert np.median(after) < np.median(before) / 5 and np.max(after) < np.max(before) / 2  # (a yaw is partly
    # a sideways step to far points: the priors still pull a little)
    np.testing.assert_allclose(np.linalg.norm(refined[:, :3, 3], axis=1), np.linalg.norm(true_motions[:, :3, 3],
                                                                                          axis=1), rtol=1e-3)
    assert stage.solves == 15 and stage.dropped_observations == 0


def test_by_default_the_stage_keeps_the_given_rotations_and_takes_the_directions_the_tracks_give():
    T, views, rng = _drive(16, seed=1)
    true_motions = relative_motions(T)
    given = true_motions.copy()
    for motion in given:  # each step's direction 0.5 degrees off, its rotation and length true
        length = np.linalg.norm(motion[:3, 3])
        motion[:3, 3] = so3_exp(rng.normal(0.0, np.radians(0.5) / np.sqrt(3), 3)) @ motion[:3, 3]
        assert np.linalg.norm(motion[:3, 3]) == pytest.approx(length)
    stage = BundleWindow(K, BundleSettings(frames=6))
    final = stage.push(0.0, None, *views[0])
    for i, motion in enumerate(given, start=1):
        final += stage.push(0.1 * i, motion, *views[i], 0.01)
    final += stage.flush()
    refined = np.stack([motion for _, motion in final])
    np.testing.assert_array_equal(refined[:, :3, :3], given[:, :3, :3])

    def direction_error_rad(motions: np.ndarray) -> np.ndarray:
        cosine = np.einsum("ij,ij->i", motions[:, :3, 3], true_motions[:, :3, 3]) / (
            np.linalg.norm(motions[:, :3, 3], axis=1) * np.linalg.norm(true_motions[:, :3, 3], axis=1))
        return np.arccos(np.clip(cosine, -1.0, 1.0))

    # the priors hold the directions too (1 % of the step sideways), and far points tell a sideways step from a
    # yaw only in part: the directions move a third of the way, not all of it
    assert np.median(direction_error_rad(refined)) < 0.75 * np.median(direction_error_rad(given))


def test_solving_every_third_frame_solves_a_third_as_often_and_still_gives_every_motion():
    T, views, _ = _drive(13)
    stage = BundleWindow(K, BundleSettings(frames=4, every=3))
    final = stage.push(0.0, None, *views[0])
    for i, motion in enumerate(relative_motions(T), start=1):
        final += stage.push(0.1 * i, motion, *views[i])
    final += stage.flush()
    assert stage.solves == 4 + 1  # 12 steps, and the flush
    np.testing.assert_allclose(np.stack([motion for _, motion in final]), relative_motions(T), atol=1e-9)


def test_only_the_first_frame_comes_without_a_motion():
    stage = BundleWindow(K)
    ids, px = np.zeros(0, np.int64), np.zeros((0, 2))
    with pytest.raises(ValueError, match="the first frame must come first"):
        stage.push(0.1, np.eye(4), ids, px)
    stage.push(0.0, None, ids, px)
    with pytest.raises(ValueError, match="only the first frame"):
        stage.push(0.1, None, ids, px)
    assert stage.push(0.1, np.eye(4), ids, px) == [] and stage.flush()[0][0] == 0.1  # no tracks: the motion as given


def test_tracks_follow_the_image_keep_their_ids_and_new_ones_fill_the_room():
    rng = np.random.default_rng(5)
    image = cv2.GaussianBlur((rng.random((120, 200)) * 255).astype(np.uint8), (0, 0), 1.5)
    shifted = cv2.warpAffine(image, np.array([[1.0, 0.0, 3.0], [0.0, 1.0, 2.0]]), (200, 120),
                             borderMode=cv2.BORDER_REFLECT)
    grid = np.stack(np.meshgrid(np.arange(20, 180, 8.0), np.arange(20, 100, 8.0)), axis=-1).reshape(-1, 2)
    tracker = LandmarkTracker(spacing_px=16.0, return_px=0.5, max_tracks=40)
    first = tracker.advance(image, grid)
    assert len(first.ids) == 40 and len(np.unique(first.ids)) == 40
    second = tracker.advance(shifted, grid + [3.0, 2.0])
    kept = np.isin(second.ids, first.ids)
    assert kept.sum() >= 36  # almost all followed
    moved = second.px[kept] - first.px[np.searchsorted(first.ids, second.ids[kept])]
    np.testing.assert_allclose(moved, np.tile([3.0, 2.0], (kept.sum(), 1)), atol=0.05)
    other = cv2.GaussianBlur((rng.random((120, 200)) * 255).astype(np.uint8), (0, 0), 1.5)
    third = tracker.advance(other, grid)  # another view altogether: the tracks end, new ones take their room
    new = third.ids >= 40
    assert len(third.ids) == 40 and new.sum() >= 36
    assert len(np.unique(np.floor(third.px / 16.0), axis=0)) == 40  # one track a cell


def test_tracks_measured_again_from_their_first_frame_follow_the_view_and_end_at_their_age():
    rng = np.random.default_rng(6)
    image = cv2.GaussianBlur((rng.random((120, 200)) * 255).astype(np.uint8), (0, 0), 1.5)
    grid = np.stack(np.meshgrid(np.arange(30, 170, 8.0), np.arange(30, 90, 8.0)), axis=-1).reshape(-1, 2)
    tracker = LandmarkTracker(spacing_px=16.0, return_px=0.5, agree_px=1.0, max_tracks=30, max_age=3)
    started = tracker.advance(image, grid)
    for frame in range(1, 5):  # the view slides 0.37 px a frame to the right
        shifted = cv2.warpAffine(image, np.array([[1.0, 0.0, 0.37 * frame], [0.0, 1.0, 0.0]]), (200, 120),
                                 flags=cv2.INTER_CUBIC, borderMode=cv2.BORDER_REFLECT)
        seen = tracker.advance(shifted, grid)
        first = np.isin(seen.ids, started.ids)
        if frame <= 3:
            assert first.sum() >= 28
            moved = seen.px[first] - started.px[np.searchsorted(started.ids, seen.ids[first])]
            np.testing.assert_allclose(np.median(moved, axis=0), [0.37 * frame, 0.0], atol=0.06)  # LK's own bias
        else:
            assert not first.any() and len(seen.ids) == 30  # 4 frames old: ended, and new ones took the room
