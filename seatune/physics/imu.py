"""Strapdown IMU model: orientation quaternion, body angular rates and specific force.

Body FLU axes (DESIGN §3), world ENU (REP-103). Attitude is the ZYX Euler sequence
(yaw about z, then pitch about y, then roll about x) — the small-angle η4, η5, η6 of the linear model.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

G = 9.81


def attitude(roll: np.ndarray, pitch: np.ndarray, yaw_enu: np.ndarray) -> Rotation:
    """Rotation body → world (ENU) from ZYX Euler angles [rad]."""
    return Rotation.from_euler("ZYX", np.stack([yaw_enu, pitch, roll], axis=-1))


def body_rates(roll, pitch, roll_rate, pitch_rate, yaw_rate) -> np.ndarray:
    """(T, 3) body angular velocity [rad/s] from ZYX Euler angles and their time derivatives."""
    sr, cr = np.sin(roll), np.cos(roll)
    sp, cp = np.sin(pitch), np.cos(pitch)
    p = roll_rate - yaw_rate * sp
    q = pitch_rate * cr + yaw_rate * sr * cp
    r = -pitch_rate * sr + yaw_rate * cr * cp
    return np.stack([p, q, r], axis=-1)


def specific_force(rotation: Rotation, accel_world: np.ndarray, g: float = G) -> np.ndarray:
    """(T, 3) accelerometer reading in body axes: Rᵀ (a − g_vec), g_vec = (0, 0, −g) in ENU."""
    return rotation.inv().apply(accel_world + np.array([0.0, 0.0, g]))


def compass_to_enu_yaw(heading_deg: np.ndarray) -> np.ndarray:
    """ROS ENU yaw [rad] (0 = East, counter-clockwise) from a compass heading [deg]: ψ = 90° − yaw."""
    return np.radians(90.0 - np.asarray(heading_deg))
