"""Voyage plan → vessel kinematics: heading, velocity and position on a local east/north plane.

Segments follow each other; between two segments heading and velocity change smoothly over a
transition (half-cosine), so a turn or a speed change takes time as on a real vessel.
Headings are compass degrees (clockwise from North); velocities and positions are east/north.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

EARTH_RADIUS = 6_371_000.0


@dataclass(frozen=True)
class Segment:
    kind: str  # "transit", "drift" or "station_keeping"
    start: float  # s from the trial start
    duration: float  # s
    heading_deg: float  # heading at the segment start (course for a transit)
    heading_rate_deg_s: float = 0.0  # slow heading drift while drifting
    speed: float = 0.0  # m/s over ground
    course_deg: float = 0.0  # direction of the velocity (compass)

    @property
    def end(self) -> float:
        return self.start + self.duration

    @property
    def free_floating(self) -> bool:
        return self.kind in ("drift", "station_keeping")


@dataclass(frozen=True)
class Kinematics:
    t: np.ndarray  # (T,) s
    heading_deg: np.ndarray  # (T,) compass
    heading_rate: np.ndarray  # (T,) rad/s, clockwise positive (compass)
    velocity_en: np.ndarray  # (T, 2) m/s
    acceleration_en: np.ndarray  # (T, 2) m/s^2
    position_en: np.ndarray  # (T, 2) m from the start position
    segment: np.ndarray  # (T,) index of the active segment

    def latlon(self, lat0: float, lon0: float) -> tuple[np.ndarray, np.ndarray]:
        """Latitude/longitude [deg] of the track (local tangent plane; fine over tens of km)."""
        lat = lat0 + np.degrees(self.position_en[:, 1] / EARTH_RADIUS)
        lon = lon0 + np.degrees(self.position_en[:, 0] / (EARTH_RADIUS * np.cos(np.radians(lat0))))
        return lat, (lon + 180.0) % 360.0 - 180.0


def _unwrap_deg(values: np.ndarray) -> np.ndarray:
    return np.degrees(np.unwrap(np.radians(values)))


def _velocity(seg: Segment) -> np.ndarray:
    c = np.radians(seg.course_deg)
    return np.array([seg.speed * np.sin(c), seg.speed * np.cos(c)])


def kinematics(segments: list[Segment], t: np.ndarray, transition: float = 120.0) -> Kinematics:
    """Sample the plan at times t; heading and velocity blend over `transition` s at each boundary."""
    starts = np.array([s.start for s in segments])
    idx = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(segments) - 1)
    seg_start = starts[idx]
    head0 = _unwrap_deg(np.array([s.heading_deg for s in segments]))
    rate = np.array([s.heading_rate_deg_s for s in segments])
    heading = head0[idx] + rate[idx] * (t - seg_start)
    vel = np.array([_velocity(s) for s in segments])[idx]
    for k in range(1, len(segments)):  # blend across each boundary
        prev, cur = segments[k - 1], segments[k]
        lo, hi = cur.start - transition / 2, cur.start + transition / 2
        inside = (t >= lo) & (t < hi)
        if not inside.any():
            continue
        s = 0.5 - 0.5 * np.cos(np.pi * (t[inside] - lo) / transition)
        h_prev = head0[k - 1] + prev.heading_rate_deg_s * (t[inside] - prev.start)
        h_cur = head0[k] + cur.heading_rate_deg_s * (t[inside] - cur.start)
        diff = (h_cur - h_prev + 180.0) % 360.0 - 180.0  # turn the short way
        heading[inside] = h_prev + s * diff
        vel[inside] = _velocity(prev) + s[:, None] * (_velocity(cur) - _velocity(prev))
    dt = np.gradient(t)
    pos = np.concatenate([[[0.0, 0.0]], np.cumsum(0.5 * (vel[1:] + vel[:-1]) * np.diff(t)[:, None], axis=0)])
    return Kinematics(
        t=t, heading_deg=np.mod(heading, 360.0), heading_rate=np.radians(np.gradient(heading) / dt),
        velocity_en=vel, acceleration_en=np.gradient(vel, axis=0) / dt[:, None], position_en=pos, segment=idx,
    )
