"""An independent, literal re-implementation of the KITTI devkit's evaluate_odometry.cpp for tests.

Written as plain loops over lists of 4x4 matrices, with float32 error records like the C++ ``errors``
struct, so that it shares no code path with flowvo.metrics.kitti_odometry.
"""

import math

import numpy as np

LENGTHS = [100, 200, 300, 400, 500, 600, 700, 800]


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


def sequence_errors(poses_gt, poses_result):
    errors = []
    n = len(poses_gt)
    dist = [0.0]
    for i in range(1, n):
        d = poses_gt[i][:3, 3] - poses_gt[i - 1][:3, 3]
        dist.append(dist[i - 1] + math.sqrt(d[0] ** 2 + d[1] ** 2 + d[2] ** 2))
    for first in range(0, n, 10):
        for length in LENGTHS:
            last = -1
            for i in range(first, n):
                if dist[i] > dist[first] + length:
                    last = i
                    break
            if last == -1 or first not in poses_result or last not in poses_result:
                continue
            delta_gt = np.linalg.inv(poses_gt[first]) @ poses_gt[last]
            delta_result = np.linalg.inv(poses_result[first]) @ poses_result[last]
            error = np.linalg.inv(delta_result) @ delta_gt
            d = 0.5 * (error[0, 0] + error[1, 1] + error[2, 2] - 1.0)
            r_err = math.acos(max(min(d, 1.0), -1.0))
            t_err = math.sqrt(error[0, 3] ** 2 + error[1, 3] ** 2 + error[2, 3] ** 2)
            speed = length / (0.1 * (last - first + 1))
            errors.append(np.float32([first, r_err / length, t_err / length, length, speed]))
    return errors


def averages(errors):
    t = sum(float(e[2]) for e in errors) / len(errors)
    r = sum(float(e[1]) for e in errors) / len(errors)
    return 100.0 * t, math.degrees(r)
