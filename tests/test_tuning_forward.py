"""The tuning forward model against the physics core's channel statistics (itself checked against Capytaine's
RAOs and a direct Σ_β sum in test_physics_core), and the self-similar sea-state scaling."""

import numpy as np
import pytest

from seatune.physics.response import channel_statistics
from seatune.tuning.forward import ChannelPower, WindowStatistics

CHANNELS = ["roll", "pitch", "imu_fz"]


def sea_on_grid(db, hs=2.0, tp=9.0, dir_from=240.0, heading=300.0):
    """A JONSWAP + cos-2s sea given on coming-from directions D every 15°; and the same sea on the database's β."""
    from seatune.physics.spectra import SpectrumPartition, discrete_spreading

    dirs = np.arange(24) * 15.0
    s1 = SpectrumPartition(hs=hs, tp=tp, dir_from_deg=dir_from).spectrum(db.omega)
    spread = discrete_spreading(np.radians(dirs), np.radians(dir_from), "cos2s", 4.0)
    s2d = s1[:, None] * spread[None, :]  # per rad
    beta = np.mod(heading - dirs - 180.0, 360.0)  # DESIGN §3
    order = np.argsort(beta)
    assert np.allclose(np.sort(beta), np.degrees(db.wave_direction))  # the 15° grids coincide
    return s2d, dirs, s2d[:, order], heading


def test_forward_sigma_equals_channel_statistics(sample_model):
    db = sample_model.db
    s2d, dirs, on_beta, heading = sea_on_grid(db)
    power = ChannelPower(sample_model, ["r44", "beta44"], CHANNELS)
    names = [f"{c}:{s}" for c in CHANNELS for s in ("sigma", "tz")]
    hs0 = 4 * np.sqrt(np.trapezoid(s2d.sum(axis=1) * np.radians(15.0), db.omega))
    model = WindowStatistics(power, names, s2d, dirs, heading, (hs0, 9.0, 0.0), {})
    phi = np.array([[8.4, 0.07], [9.2, 0.04]])
    pred = model.predict(phi, np.array([[hs0, 9.0, 0.0]]))[:, 0, :]
    loading = sample_model.loading(r44=phi[:, 0], beta44=phi[:, 1])
    sigma, tz = channel_statistics(db, loading, [sample_model.channel(c) for c in CHANNELS], on_beta)
    expected = np.stack([sigma, tz], axis=-1).reshape(2, -1)
    np.testing.assert_allclose(pred, expected, rtol=1e-5)  # float32 channel power and sums
    paired = model.predict_paired(phi, np.array([[hs0, 9.0, 0.0]] * 2))
    np.testing.assert_allclose(paired, pred, rtol=1e-6)


def test_hs_scaling_and_direction_rotation(sample_model):
    db = sample_model.db
    s2d, dirs, _, heading = sea_on_grid(db)
    power = ChannelPower(sample_model, ["r44"], CHANNELS)
    model = WindowStatistics(power, [f"{c}:sigma" for c in CHANNELS], s2d, dirs, heading, (2.0, 9.0, 0.0), {})
    phi = np.array([[8.4]])
    base, double = model.predict(phi, np.array([[2.0, 9.0, 0.0], [4.0, 9.0, 0.0]]))[0]
    np.testing.assert_allclose(double, 2 * base, rtol=1e-6)  # σ ∝ Hs
    # rotating the hypothesis by 30° equals the sea coming from 30° less (β = ψ − D − 180°)
    rotated = model.predict(phi, np.array([[2.0, 9.0, 30.0]]))[0, 0]
    s2d_b, dirs_b, _, _ = sea_on_grid(db, dir_from=210.0)
    other = WindowStatistics(power, model.names, s2d_b, dirs_b, heading, (2.0, 9.0, 0.0), {})
    np.testing.assert_allclose(rotated, other.predict(phi, np.array([[2.0, 9.0, 0.0]]))[0, 0], rtol=1e-5)
    assert model.predict(phi, np.array([[2.0, 9.0, 360.0]]))[0, 0] == pytest.approx(base, rel=1e-6)
