"""Channels: what sensors measure, as linear maps t_j(ω) of the 6-DOF motion ξ (DESIGN §4).

x_j = t_jᵀ ξ with ξ = (η1, η2, η3, η4, η5, η6) about the body origin, complex amplitudes under
x(t) = Re{X e^{−iωt}} so that d/dt ↔ −iω. Point channels use the small-angle rigid-body transform
s(p) = ξ_t + θ × p; the accelerometer's specific force adds the gravity tilt
f_x = a_x − g η5, f_y = a_y + g η4 (body axes, first order).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

AXES = {"x": 0, "y": 1, "z": 2}
KINDS = ("angle", "rate", "displacement", "velocity", "acceleration", "specific_force")


@dataclass(frozen=True)
class Channel:
    name: str
    kind: str
    axis: str
    point: tuple[float, float, float] | None = None  # hull frame: z above baseline

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ValueError(f"unknown channel kind {self.kind!r}")
        if self.axis not in AXES:
            raise ValueError(f"unknown axis {self.axis!r}")


def point_translation(point_body: np.ndarray, axis: int) -> np.ndarray:
    """Row vector r with r·ξ = displacement of `point_body` (..., 3) along `axis`: ξ_t + θ × p."""
    x, y, z = point_body[..., 0], point_body[..., 1], point_body[..., 2]
    o = np.zeros_like(x)
    one = np.ones_like(x)
    rows = {
        0: (one, o, o, o, z, -y),
        1: (o, one, o, -z, o, x),
        2: (o, o, one, y, -x, o),
    }[axis]
    return np.stack(rows, axis=-1)


def transfer_vectors(channels: list[Channel], omega: np.ndarray, draft: np.ndarray, g: float) -> np.ndarray:
    """t_j(ω) for every condition, frequency and channel.

    Parameters
    ----------
    channels : list of Channel (points in the hull frame)
    omega : (nw,) rad/s
    draft : (N,) m, draft of each loading condition (moves the body origin to its waterline)
    g : gravity [m/s^2]

    Returns
    -------
    t : (N, nw, 6, nch) complex
    """
    n, nw = draft.shape[0], omega.shape[0]
    t = np.zeros((n, nw, 6, len(channels)), dtype=complex)
    iw = -1j * omega[None, :, None]  # d/dt
    for j, ch in enumerate(channels):
        a = AXES[ch.axis]
        if ch.kind in ("angle", "rate"):
            e = np.zeros(6)
            e[3 + a] = 1.0
            t[:, :, :, j] = e * (iw if ch.kind == "rate" else 1.0)
            continue
        p = np.array(ch.point, dtype=float)
        p_body = np.stack([np.full(n, p[0]), np.full(n, p[1]), p[2] - draft], axis=-1)
        r = point_translation(p_body, a)[:, None, :]  # (N, 1, 6)
        if ch.kind == "displacement":
            t[:, :, :, j] = r
        elif ch.kind == "velocity":
            t[:, :, :, j] = iw * r
        else:
            t[:, :, :, j] = iw**2 * r
            if ch.kind == "specific_force" and a < 2:
                tilt = np.zeros(6)
                tilt[4 if a == 0 else 3] = -g if a == 0 else g  # f_x = a_x − g η5, f_y = a_y + g η4
                t[:, :, :, j] += tilt
    return t
