"""An independent, literal re-implementation of the KITTI devkit's evaluate_odometry.cpp for tests.

Written as plain loops over lists of 4x4 matrices with scalar arithmetic that mirrors the C++ types:
``Matrix`` (poses, inverses, products) in double, every ``float`` variable (distances, the error's
diagonal sum, its ``acos``, the translation norm, the per-length errors and the running sums) in
float32, so that it shares no code path with flowvo.metrics.kitti_odometry.
"""

import math

import numpy as np

LENGTHS = [100, 200, 300, 400, 500, 600, 700, 800]
f32 = np.float32


def load_poses(path):
    poses = {}
    with open(path) as handle:
        for count, line in enumerate(handle):
            values = [float(v) for v in line.split()]
            index = int(values[0]) if len(values) == 13 else count
            matrix = np.eye(4)
            matrix[:3, :] = np.array(values[-12:]).reshape(3, 4)
            poses[index] = matrix
    return poses


def trajectory_distances(poses):
    dist = [f32(0.0)]
    for i in range(1, len(poses)):
        p1, p2 = poses[i - 1], poses[i]
        dx, dy, dz = f32(p1[0, 3] - p2[0, 3]), f32(p1[1, 3] - p2[1, 3]), f32(p1[2, 3] - p2[2, 3])
        dist.append(f32(dist[i - 1] + f32(math.sqrt(f32(f32(dx * dx) + f32(dy * dy)) + f32(dz * dz)))))
    return dist


def rotation_error(error):
    a, b, c = f32(error[0, 0]), f32(error[1, 1]), f32(error[2, 2])
    d = f32(0.5 * (float(f32(f32(a + b) + c)) - 1.0))
    return f32(math.acos(float(max(min(d, f32(1.0)), f32(-1.0)))))


def translation_error(error):
    dx, dy, dz = f32(error[0, 3]), f32(error[1, 3]), f32(error[2, 3])
    return f32(math.sqrt(f32(f32(dx * dx) + f32(dy * dy)) + f32(dz * dz)))


def sequence_errors(poses_gt, poses_result):
    errors = []
    n = len(poses_gt)
    dist = trajectory_distances(poses_gt)
    for first in range(0, n, 10):
        for length in LENGTHS:
            last = -1
            for i in range(first, n):
                if dist[i] > f32(dist[first] + f32(length)):
                    last = i
                    break
            if last == -1 or first not in poses_result or last not in poses_result:
                continue
            delta_gt = np.linalg.inv(poses_gt[first]) @ poses_gt[last]
            delta_result = np.linalg.inv(poses_result[first]) @ poses_result[last]
            error = np.linalg.inv(delta_result) @ delta_gt
            speed = f32(length / (0.1 * float(f32(last - first + 1))))
            errors.append((first, f32(rotation_error(error) / f32(length)),
                           f32(translation_error(error) / f32(length)), length, speed))
    return errors


def averages(errors):
    t, r = f32(0.0), f32(0.0)
    for error in errors:
        t = f32(t + error[2])
        r = f32(r + error[1])
    num = f32(len(errors))
    return 100.0 * float(f32(t / num)), math.degrees(float(f32(r / num)))
