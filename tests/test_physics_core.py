"""Physics core against independent sources: Capytaine's own RAO and hydrostatics, analytic formulas,
kinetic energy of point masses, a time-domain rotation of gravity, the IMO roll-period formula."""

import numpy as np
import pytest
import xarray as xr
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from seatune.physics.channels import Channel, transfer_vectors
from seatune.physics.hydro import DOFS
from seatune.physics.loading import Loading, load, rigid_body_mass_matrix
from seatune.physics.response import (
    channel_raos,
    channel_statistics,
    motion_raos,
    natural_frequencies,
    trapezoid_weights,
)


def conditions(model, n_per_draft=2):
    """Loading conditions exactly at database drafts (mass = ρ V_k) with varied COG, radii, damping."""
    db = model.db
    rng = np.random.default_rng(7)
    rows, draft_idx = [], []
    for k in (0, 2, 4):
        for _ in range(n_per_draft):
            rows.append(dict(
                mass=db.rho * db.disp_volume[k], xcg=rng.uniform(-3, 2), ycg=rng.uniform(-0.5, 0.5),
                zcg=rng.uniform(5.8, 7.2), r44=rng.uniform(7, 10), r55=rng.uniform(21, 27), r66=rng.uniform(22, 28),
                gmt_fs=rng.uniform(0, 0.6), gml_fs=rng.uniform(0, 1), beta33=rng.uniform(0, 0.05),
                beta44=rng.uniform(0.02, 0.14), beta55=rng.uniform(0, 0.05)))
            draft_idx.append(k)
    return Loading(**{k: np.array([r[k] for r in rows]) for k in rows[0]}), draft_idx


def capytaine_dataset(ds, k, M, C):
    """Capytaine-layout dataset of database draft k with the condition's inertia and stiffness."""
    sub = ds.isel(draft=k)
    dofs = list(DOFS)
    coords = {"influenced_dof": dofs, "radiating_dof": dofs}
    out = xr.Dataset({
        "added_mass": sub["added_mass"], "radiation_damping": sub["radiation_damping"],
        "excitation_force": sub["excitation_force"],
        "inertia_matrix": xr.DataArray(M, dims=("influenced_dof", "radiating_dof"), coords=coords),
        "hydrostatic_stiffness": xr.DataArray(C, dims=("influenced_dof", "radiating_dof"), coords=coords),
    })
    return out


def test_raos_equal_capytaine_post_pro_rao(sample_model, sample_dataset):
    import capytaine as cpt

    loading, draft_idx = conditions(sample_model)
    lh = load(sample_model.db, loading)
    ours = motion_raos(sample_model.db, loading)
    dofs = list(DOFS)
    for n, k in enumerate(draft_idx):
        ds = capytaine_dataset(sample_dataset, k, lh.mass_matrix[n], lh.stiffness[n])
        dissipation = xr.DataArray(lh.extra_damping[n], dims=("influenced_dof", "radiating_dof"),
                                   coords={"influenced_dof": dofs, "radiating_dof": dofs})
        ref = cpt.post_pro.rao(ds, dissipation=dissipation).transpose("omega", "wave_direction", "radiating_dof")
        ref = ref.sel(radiating_dof=dofs).values
        scale = np.abs(ref).max(axis=(0, 1))
        assert np.max(np.abs(ours[n] - ref) / scale) < 1e-8


def test_stiffness_equals_capytaine_hydrostatics(sample_model):
    import capytaine as cpt

    from seatune.physics.hull import hull_mesh

    p = sample_model.spec.hull.parametric
    hull = p.hull()
    db = sample_model.db
    for k in (0, 3):
        draft = db.drafts[k]
        mesh, _ = hull_mesh(hull, draft, p.stations, p.girth_panels)
        mesh = cpt.Mesh(mesh.merged().vertices, mesh.merged().faces, quadrature_method="Gauss-Legendre 2")
        mass = db.rho * db.disp_volume[k]
        cog = np.array([-1.3, 0.2, 6.8 - draft])
        body = cpt.FloatingBody(mesh=mesh, dofs=cpt.rigid_body_dofs(rotation_center=(0, 0, 0)),
                                center_of_mass=tuple(cog), mass=mass)
        ref = body.compute_hydrostatic_stiffness(rho=db.rho, g=db.g).sel(
            influenced_dof=list(DOFS), radiating_dof=list(DOFS)).values
        loading = Loading(mass=mass, xcg=cog[0], ycg=cog[1], zcg=6.8, r44=8, r55=24, r66=25, gmt_fs=0, gml_fs=0,
                          beta33=0, beta44=0, beta55=0)
        ours = load(db, loading).stiffness[0]
        assert_allclose(ours, ref, rtol=1e-8, atol=1e-8 * np.abs(ref).max())


def test_mass_matrix_gives_kinetic_energy_of_point_masses():
    """½ qᵀ M q equals Σ ½ m_i |v + ω × r_i|² for a cloud with the same mass, COG and radii."""
    rng = np.random.default_rng(1)
    cog = np.array([2.0, -0.5, 1.5])
    # six equal masses at ±d_k on each axis about the COG: I_xx = m (d_y² + d_z²)/3 etc.
    d = np.array([5.0, 12.0, 14.0])
    m_total = 6.0e6
    pts = np.concatenate([cog + s * d[i] * np.eye(3)[i] for i in range(3) for s in (1, -1)]).reshape(6, 3)
    mi = m_total / 6
    radii = np.sqrt(np.array([d[1] ** 2 + d[2] ** 2, d[0] ** 2 + d[2] ** 2, d[0] ** 2 + d[1] ** 2]) / 3)
    M = rigid_body_mass_matrix(np.array([m_total]), cog[None], radii[None])[0]
    for _ in range(5):
        v, w = rng.normal(size=3), rng.normal(size=3)
        energy = 0.5 * mi * np.sum(np.linalg.norm(v + np.cross(w, pts), axis=1) ** 2)
        q = np.r_[v, w]
        assert_allclose(0.5 * q @ M @ q, energy, rtol=1e-12)


@pytest.fixture(scope="module")
def base_raos(sample_model):
    return motion_raos(sample_model.db, sample_model.base_loading)[0]  # (nw, nb, 6)


@settings(max_examples=24, deadline=None)
@given(k=st.integers(0, 23))
def test_long_and_short_wave_limits(sample_model, base_raos, k):
    """OrcaFlex RAO quality checks (spec/ecosystem.md): long waves heave → 1, pitch → |cos β| × slope;
    short waves → 0; no roll, sway or yaw in head and following seas (mirror symmetry)."""
    db, xi = sample_model.db, base_raos
    beta = db.wave_direction[k]
    assert abs(xi[0, k, 2]) == pytest.approx(1.0, abs=0.01)  # λ = 1540 m ≫ L: the hull follows the surface
    slope = db.omega[0] ** 2 / db.g
    assert abs(xi[0, k, 4]) / slope == pytest.approx(abs(np.cos(beta)), abs=0.01)
    assert np.all(np.abs(xi[-1, k, :3]) < 0.1)  # λ = 15 m ≪ L = 96 m
    assert np.all(np.abs(xi[-1, k, 3:]) < 0.02 * db.omega[-1] ** 2 / db.g)  # rotations ≪ the wave slope
    if np.isclose(np.sin(beta), 0.0, atol=1e-12):
        # BEM noise of the mirrored non-planar panels leaves ~3e-3 of the beam-sea roll
        beam = np.abs(xi[:, :, [1, 3, 5]]).max(axis=(0, 1))
        assert np.all(np.abs(xi[:, k, [1, 3, 5]]).max(axis=0) < 5e-3 * beam)


def test_natural_frequencies_are_roots_of_the_coupled_determinant(sample_model, sample_dataset):
    """ω_n are the roots of det(C − ω²(M + A(ω))) on the full 6×6 problem, A(ω) interpolated with xarray from the
    committed database (not seatune's reader), the roots bracketed by a scan and polished by brentq."""
    from scipy.optimize import brentq

    db = sample_model.db
    loading, draft_idx = conditions(sample_model, n_per_draft=1)
    lh = load(db, loading)
    ours = natural_frequencies(db, loading)
    grid = np.linspace(0.3, 1.5, 600)
    for n, k in enumerate(draft_idx):
        a = sample_dataset["added_mass"].isel(draft=k).sel(influenced_dof=list(DOFS), radiating_dof=list(DOFS))
        m, c = lh.mass_matrix[n], lh.stiffness[n]

        def det(w, m=m, c=c, a=a):  # the three zero-stiffness DOFs contribute ω⁶
            return np.linalg.det(c - w**2 * (m + a.interp(omega=w).values)) / w**6

        d = np.array([det(w) for w in grid])
        roots = [brentq(det, grid[i], grid[i + 1], xtol=1e-14) for i in np.flatnonzero(np.diff(np.sign(d)))]
        assert sorted(ours[n]) == pytest.approx(roots, rel=1e-8)


def test_roll_period_within_15_percent_of_imo(sample_model):
    from seatune.pipeline.vessel_report import vessel_summary

    s = vessel_summary(sample_model)
    length, beam, draft, gm = 96.0, 22.0, s["draft_m"], s["gmt_m"]
    f = 0.373 + 0.023 * beam / draft - 0.043 * length / 100  # IMO A.749 (spec/ecosystem.md)
    t_imo = 2 * f * beam / np.sqrt(gm)
    assert s["natural_period_roll_s"] == pytest.approx(t_imo, rel=0.15)
    assert 8 <= s["natural_period_roll_s"] <= 14
    assert 1 <= gm <= 3


def test_sigma_by_sff_path_equals_direct_sum_over_directions(sample_model, sample_dataset):
    """σ from S_FF equals Σ_β |H_j|² S Δβ with H_j from Capytaine's RAO (incl. a between-drafts condition)."""
    import capytaine as cpt

    from seatune.physics.spectra import SpectrumPartition, directional_spectrum

    db = sample_model.db
    loading, draft_idx = conditions(sample_model, n_per_draft=1)
    mid = loading.take(slice(0, 1)).with_values(mass=np.array([db.rho * 0.5 * (db.disp_volume[1] + db.disp_volume[2])]))
    channels = sample_model.channels
    seas = [
        [SpectrumPartition(hs=2.5, tp=9.0, dir_from_deg=200.0, gamma=3.3, spreading="cos2s", spreading_param=6)],
        [SpectrumPartition(hs=1.5, tp=7.0, dir_from_deg=30.0, gamma=2.0, spreading="cosn", spreading_param=2),
         SpectrumPartition(hs=1.0, tp=13.0, dir_from_deg=290.0, gamma=5.0, spreading="cos2s", spreading_param=20)],
    ]
    dofs = list(DOFS)
    w_om = trapezoid_weights(db.omega)
    dbeta = 2 * np.pi / db.wave_direction.size
    for sea in seas:
        S = directional_spectrum(db.omega, db.wave_direction, sea, heading_deg=75.0)
        for lo, k in [(loading, draft_idx), (mid, [None])]:
            sigma, _ = channel_statistics(db, lo, channels, S)
            lh = load(db, lo)
            t = transfer_vectors(channels, db.omega, lh.draft, db.g)
            for n, kk in enumerate(k):
                ds_k = (sample_dataset.isel(draft=kk) if kk is not None
                        else sample_dataset.interp(draft=float(lh.draft[n])))
                ds = capytaine_dataset(ds_k.expand_dims("draft"), 0, lh.mass_matrix[n], lh.stiffness[n])
                diss = xr.DataArray(lh.extra_damping[n], dims=("influenced_dof", "radiating_dof"),
                                    coords={"influenced_dof": dofs, "radiating_dof": dofs})
                xi = cpt.post_pro.rao(ds, dissipation=diss).transpose("omega", "wave_direction", "radiating_dof")
                h = np.einsum("wbd,wdc->wbc", xi.sel(radiating_dof=dofs).values, t[n])
                direct = np.sqrt(np.einsum("wbc,wb,w->c", np.abs(h) ** 2, S * dbeta, w_om))
                assert_allclose(sigma[n], direct, rtol=1e-10)


@pytest.mark.parametrize("amp", [0.02])
def test_specific_force_matches_rotated_gravity(amp):
    """Linear f = a − g(η5, −η4) vs the exact R(q)ᵀ(a_p + g e_z) of a harmonic roll/pitch motion."""
    from scipy.spatial.transform import Rotation

    g, w = 9.81, 0.7
    p = np.array([12.0, 3.0, 9.0])  # body frame
    chans = [Channel(f"f{a}", "specific_force", a, tuple(p)) for a in "xyz"]

    def max_error(a):
        xi = np.array([0, 0, 0, a, 0.7 * a * np.exp(-1j * 0.9), 0.3 * a * np.exp(-1j * 0.4)])
        tv = transfer_vectors(chans, np.array([w]), np.array([0.0]), g)[0, 0]  # (6, 3)
        tt = np.linspace(0, 2 * np.pi / w, 400)
        lin = np.real(np.outer(np.exp(-1j * w * tt), xi @ tv))
        dt = 1e-3

        def world_point(t):
            ang = np.real(xi[3:, None] * np.exp(-1j * w * t))  # roll, pitch, yaw
            R = Rotation.from_euler("ZYX", np.c_[ang[2], ang[1], ang[0]])
            return R, R.apply(np.tile(p, (len(t), 1)))

        R, _ = world_point(tt)
        acc = (world_point(tt + dt)[1] - 2 * world_point(tt)[1] + world_point(tt - dt)[1]) / dt**2
        exact = R.inv().apply(acc + np.array([0, 0, g])) - np.array([0, 0, g])
        return np.abs(exact - lin).max()

    e1, e2 = max_error(amp), max_error(amp / 2)
    assert e1 < 3 * g * amp**2  # second order in the angle
    assert 3.0 < e1 / e2 < 5.0  # halving the angle quarters the error


def test_channel_raos_follow_rigid_body_kinematics(sample_model):
    """Heave at a point = η3 + y η4 − x η5 (spec/seed_A1_A2.md §2.4); velocity −iω, acceleration −ω²."""
    db = sample_model.db
    lo = sample_model.base_loading
    xi = motion_raos(db, lo)[0]
    h = channel_raos(db, lo, sample_model.channels)[0]
    names = [c.name for c in sample_model.channels]
    x, y = -46.0, 8.0
    disp = xi[..., 2] + y * xi[..., 3] - x * xi[..., 4]
    assert_allclose(h[..., names.index("heave_disp_C")], disp, rtol=1e-12)
    iw = -1j * db.omega[:, None]
    assert_allclose(h[..., names.index("heave_vel_C")], iw * disp, rtol=1e-12)
    assert_allclose(h[..., names.index("heave_acc_C")], iw**2 * disp, rtol=1e-12)
