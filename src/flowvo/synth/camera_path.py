"""Generated drivable camera paths: straight runs and turns, speed 0..25 m/s with stops, gentle hills.

Poses are KITTI camera-to-world (x right, y down, z forward), 10 Hz, camera 1.65 m above the road.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flowvo.geometry import yaw_rotation

FRAME_PERIOD_S = 0.1
MAX_LATERAL_ACCEL_MPS2 = 3.0
MAX_ACCEL_MPS2 = 2.5


@dataclass(frozen=True)
class PathConfig:
    """Limits of a generated path (metres, seconds, radians)."""

    max_speed_mps: float = 25.0
    min_turn_radius_m: float = 15.0
    max_turn_radius_m: float = 250.0
    stop_probability: float = 0.15
    hill_amplitude_m: float = 6.0
    pitch_roll_jitter_rad: float = 0.006


def _rotation_x(angle: np.ndarray) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    o, z = np.ones_like(c), np.zeros_like(c)
    return np.stack([np.stack([o, z, z], -1), np.stack([z, c, -s], -1), np.stack([z, s, c], -1)], -2)


def _rotation_z(angle: np.ndarray) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    o, z = np.ones_like(c), np.zeros_like(c)
    return np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1), np.stack([z, z, o], -1)], -2)


def _curvature_schedule(rng: np.random.Generator, length_m: float, config: PathConfig) -> tuple[np.ndarray, np.ndarray]:
    """Arclength knots and curvature (1/m, + = right turn) of alternating straights and turns."""
    knots, curvature, s = [0.0], [0.0], 0.0
    while s < length_m:
        straight = rng.uniform(40.0, 250.0)
        radius = np.exp(rng.uniform(np.log(config.min_turn_radius_m), np.log(config.max_turn_radius_m)))
        turn_angle = rng.uniform(np.radians(25), np.radians(110))
        kappa = rng.choice([-1.0, 1.0]) / radius
        arc = turn_angle * radius
        ramp = min(10.0, arc / 3)
        knots += [s + straight, s + straight + ramp, s + straight + arc - ramp, s + straight + arc]
        curvature += [0.0, kappa, kappa, 0.0]
        s += straight + arc
    return np.asarray(knots), np.asarray(curvature)


def _speed_profile(rng: np.random.Generator, n_frames: int, config: PathConfig, curvature_at) -> np.ndarray:
    """Speed per frame (m/s) following random targets with bounded acceleration and occasional stops."""
    speeds = np.zeros(n_frames)
    speed, target, hold, s = 0.0, rng.uniform(8.0, config.max_speed_mps), 0, 0.0
    for i in range(n_frames):
        if hold > 0:
            hold -= 1
            target = 0.0 if hold > 0 else rng.uniform(5.0, config.max_speed_mps)
        elif rng.random() < 0.01:
            if rng.random() < config.stop_probability:
                target, hold = 0.0, int(rng.integers(60, 160))
            else:
                target = rng.uniform(3.0, config.max_speed_mps)
        kappa = abs(curvature_at(s + 30.0)) + abs(curvature_at(s))
        cap = np.sqrt(MAX_LATERAL_ACCEL_MPS2 / kappa) if kappa > 1e-6 else config.max_speed_mps
        wanted = min(target, cap)
        speed += np.clip(wanted - speed, -MAX_ACCEL_MPS2 * FRAME_PERIOD_S, MAX_ACCEL_MPS2 * FRAME_PERIOD_S)
        speed = max(speed, 0.0)
        speeds[i] = speed
        s += speed * FRAME_PERIOD_S
    return speeds


def generate_path(n_frames: int, seed: int, config: PathConfig | None = None) -> np.ndarray:
    """Camera-to-world poses (n_frames, 4, 4) of a generated drive, in a level world frame (y down along
    gravity): the first camera at the origin, heading along +z, pitched with the road's grade there. The
    world is built and rendered in this frame; the pose file holds the drive relative to its first camera
    (:func:`flowvo.synth.sequence_writer.write_sequence`). Taking the first camera's frame as the world's
    instead would tilt it by the starting grade: after a turn the camera then rolls against a road built
    level in that frame (a drive starting on a 6 degree grade: 6 degrees of roll after a quarter turn)."""
    config = config or PathConfig()
    rng = np.random.default_rng(seed)
    knots, kappas = _curvature_schedule(rng, n_frames * config.max_speed_mps * FRAME_PERIOD_S + 300.0, config)

    def curvature_at(s: float | np.ndarray) -> np.ndarray:
        return np.interp(s, knots, kappas)

    speeds = _speed_profile(rng, n_frames, config, curvature_at)
    step_m = np.concatenate([[0.0], speeds[1:] * FRAME_PERIOD_S])
    arclength = np.cumsum(step_m)
    # heading is the integral of curvature over arclength, evaluated finely for accuracy
    fine_s = np.linspace(0.0, max(arclength[-1], 1.0), 20 * n_frames + 2)
    mean_curvature = 0.5 * (curvature_at(fine_s[1:]) + curvature_at(fine_s[:-1]))
    fine_yaw = np.concatenate([[0.0], np.cumsum(mean_curvature * np.diff(fine_s))])
    yaw = np.interp(arclength, fine_s, fine_yaw)
    mid_yaw = np.interp(arclength - step_m / 2, fine_s, fine_yaw)
    x = np.cumsum(step_m * np.sin(mid_yaw))
    z = np.cumsum(step_m * np.cos(mid_yaw))
    phases = rng.uniform(0, 2 * np.pi, 3)
    wavelengths = np.array([900.0, 430.0, 210.0])
    amplitudes = config.hill_amplitude_m * np.array([1.0, 0.5, 0.2])

    def height(s: np.ndarray) -> np.ndarray:  # y down: negative is up
        return -np.sum(amplitudes[:, None] * np.sin(2 * np.pi * s[None] / wavelengths[:, None] + phases[:, None]), 0)

    y = height(arclength) - height(np.zeros(1))
    slope = (height(arclength + 0.5) - height(arclength - 0.5)) / 1.0
    pitch = np.arctan(-slope) + config.pitch_roll_jitter_rad * np.sin(arclength / 7.0 + phases[0])
    roll = config.pitch_roll_jitter_rad * np.sin(arclength / 11.0 + phases[1])
    poses = np.tile(np.eye(4), (n_frames, 1, 1))
    poses[:, :3, :3] = yaw_rotation(yaw) @ _rotation_x(pitch) @ _rotation_z(roll)
    poses[:, :3, 3] = np.stack([x, y, z], 1)
    return poses
