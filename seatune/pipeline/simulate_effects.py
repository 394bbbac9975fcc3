"""Extension point: physical effects the tuning model lacks, each simulated by its own mechanism.

An effect acts on the synthesised trial through hooks, never through the frequency-domain model that
diagnosis will fit: `before_sensors` may change the 6-DOF motions and channels (e.g. a nonlinear roll
equation integrated in the time domain), `imu` may change what the IMU senses (e.g. its mounting).
Register a new effect in EFFECTS; the scenario YAML names it under `effects: [{kind: ..., ...}]`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation


@dataclass
class EffectContext:
    t: np.ndarray
    fs: float
    rng: np.random.Generator
    model: object
    draft: float
    xi: dict  # {0: ξ, 1: ξ̇, 2: ξ̈}, each (T, 6)
    kin: object
    channels: dict
    imu: dict = field(default_factory=dict)  # rotation (body→world), rates, force (body axes), clean


class Effect:
    """Base class: hooks do nothing unless overridden."""

    def before_sensors(self, ctx: EffectContext, spec) -> None:
        pass

    def imu(self, ctx: EffectContext, spec) -> None:
        pass


class ImuMisalignment(Effect):
    """IMU mounted with small roll/pitch/yaw offsets [deg] (`roll_deg`, `pitch_deg`, `yaw_deg`).

    Sensor geometry: the IMU frame is the body frame rotated by R_m; it reports its own attitude
    R·R_m and measures rates and specific force in its own axes, R_mᵀ ω and R_mᵀ f.
    """

    def imu(self, ctx: EffectContext, spec) -> None:
        extra = spec.model_extra or {}
        mount = Rotation.from_euler("ZYX", [extra.get("yaw_deg", 0.0), extra.get("pitch_deg", 0.0),
                                            extra.get("roll_deg", 0.0)], degrees=True)
        ctx.imu["rotation"] = ctx.imu["rotation"] * mount
        ctx.imu["rates"] = mount.inv().apply(ctx.imu["rates"])
        ctx.imu["force"] = mount.inv().apply(ctx.imu["force"])


EFFECTS: dict[str, Effect] = {"imu_misalignment": ImuMisalignment()}
