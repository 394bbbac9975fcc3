"""Extreme response and risk from response spectra: Han A5 (RESP / RISK modules) in the thesis form, eqs. 3.10–3.13.

Pure computation. The maximum of a zero-mean Gaussian response over a sea-state duration T follows the average
upcrossing-rate (AUR) model of the thesis, eq. 3.11: upcrossings of a high level x are a Poisson stream of rate
ν0 exp(−x²/(2 m0)), so

    P(max ≤ x) = exp(−ν0 T exp(−x²/(2 m0))),    ν0 = (1/2π) √(m2/m0)  (Rice's zero-upcrossing rate).

This is the *upcrossing* form, not the narrow-band Rayleigh-peak form (P(peak ≤ x)^(N peaks)) nor A5's Rice
individual-peak distribution (A5 eq. 13, which is a per-peak probability, not the sea-state maximum; see
spec/seed_A5_A7.md §5.5–5.6). The thesis prints the PDF without T in the outer exponent; it is the derivative
of the CDF above, which has it. The uncertainty of the loading condition φ_r and of the sea state θ_s enters as a
mixture (eq. 3.12a), the exceedance probability is eq. 3.12b, and the advised heading is the argmin over the
headings (eq. 3.13).

Shapes: frequencies last for spectra; the mixture axis K (posterior points × sea-state hypotheses, flattened)
last for moments.
"""

from __future__ import annotations

import numpy as np

from seatune.physics.response import trapezoid_weights

TWO_PI = 2.0 * np.pi


def moments(omega: np.ndarray, spectra: np.ndarray, orders=(0, 2), axis: int = 0) -> np.ndarray:
    """m_n = ∫ ωⁿ S dω by the trapezoid rule (thesis eq. 3.10, A5 eq. 12) along `axis` of `spectra`.

    Returns (len(orders),) + spectra.shape without `axis`.
    """
    w = trapezoid_weights(np.asarray(omega, dtype=float))
    return np.stack([np.tensordot(w * omega**n, spectra, axes=(0, axis)) for n in orders])


def upcrossing_rate(m0: np.ndarray, m2: np.ndarray) -> np.ndarray:
    """Rice's mean zero-upcrossing rate ν0 = (1/2π) √(m2/m0) [Hz] (thesis eq. 3.11); 0 where m0 = 0."""
    m0, m2 = np.asarray(m0, dtype=float), np.asarray(m2, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(m0 > 0, np.sqrt(np.maximum(m2, 0.0) / np.where(m0 > 0, m0, 1.0)) / TWO_PI, 0.0)


def _components(m0, m2, duration_s: float) -> tuple[np.ndarray, np.ndarray]:
    """(ν0 T, 1/(2 m0)) per component; a component without energy (m0 = 0) never upcrosses (ν0 T = 0)."""
    m0 = np.asarray(m0, dtype=float)
    return upcrossing_rate(m0, m2) * duration_s, np.where(m0 > 0, 0.5 / np.where(m0 > 0, m0, 1.0), 0.0)


def _expected_upcrossings(x, m0, m2, duration_s):
    """ν0 T exp(−x²/(2 m0)): the mean number of upcrossings of level x in T (thesis eq. 3.11)."""
    n_up, inv = _components(m0, m2, duration_s)
    return n_up * np.exp(-np.square(x) * inv)


def max_cdf(x, m0, m2, duration_s: float) -> np.ndarray:
    """P(max over T ≤ x) = exp(−ν0 T exp(−x²/(2 m0))) (thesis eq. 3.11, AUR; x ≥ 0, broadcast)."""
    return np.exp(-_expected_upcrossings(x, m0, m2, duration_s))


def max_exceedance(x, m0, m2, duration_s: float) -> np.ndarray:
    """P(max over T > x) = 1 − eq. 3.11, computed as −expm1(·) so that small probabilities keep their digits."""
    return -np.expm1(-_expected_upcrossings(x, m0, m2, duration_s))


def max_pdf(x, m0, m2, duration_s: float) -> np.ndarray:
    """PDF of the maximum (thesis eq. 3.11 with T in the outer exponent): (x/m0) N(x) exp(−N(x))."""
    n_up, inv = _components(m0, m2, duration_s)
    n = n_up * np.exp(-np.square(x) * inv)
    return 2.0 * np.asarray(x) * inv * n * np.exp(-n)


def mixture_exceedance(limit: float, m0: np.ndarray, m2: np.ndarray, duration_s: float,
                       weights: np.ndarray) -> np.ndarray:
    """P(max > limit) = Σ_k w_k (1 − F_k(limit)) over the mixture axis (last) (thesis eqs. 3.12a–b).

    m0, m2: (..., K) moments of every (posterior point, sea-state hypothesis) pair; weights (K,) sum to 1
    (PMF(φ_r)·PMF(θ_s)). Returns (...).
    """
    return max_exceedance(limit, m0, m2, duration_s) @ np.asarray(weights, dtype=float)


def mixture_quantile(q: float, m0: np.ndarray, m2: np.ndarray, duration_s: float, weights: np.ndarray,
                     iterations: int = 50) -> np.ndarray:
    """The level x with mixture P(max ≤ x) = q (eq. 3.12 inverted), by bisection vectorised over (...)."""
    weights = np.asarray(weights, dtype=float)
    n_up, inv = _components(m0, m2, duration_s)
    sigma = np.sqrt(np.maximum(m0, 0.0)).max(axis=-1)
    lo = np.zeros_like(sigma)
    hi = sigma * np.sqrt(2.0 * np.log(np.maximum(n_up.max(axis=-1), np.e) / min(1.0 - q, q) + 1.0)) + 1e-300
    for _ in range(iterations):  # hi starts where F_k ≥ q for every component k
        mid = 0.5 * (lo + hi)
        below = np.exp(-n_up * np.exp(-np.square(mid[..., None]) * inv)) @ weights < q
        lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
    return 0.5 * (lo + hi)


def mixture_mode(m0: np.ndarray, m2: np.ndarray, duration_s: float, weights: np.ndarray,
                 points: int = 64, chunk_elements: int = 2_000_000) -> np.ndarray:
    """Most probable maximum: the mode of the mixture PDF Σ_k w_k f_k(x) (eq. 3.12a with eq. 3.11's PDF),
    on `points` levels between the mixture's 0.1 % and 99.9 % quantiles, refined by a parabola through the best
    three. Vectorised over (...), in chunks that keep the (chunk, points, K) temporaries small."""
    weights = np.asarray(weights, dtype=float)
    shape = m0.shape[:-1]
    m0, m2 = m0.reshape(-1, m0.shape[-1]), m2.reshape(-1, m2.shape[-1])
    lo = mixture_quantile(0.001, m0, m2, duration_s, weights, iterations=30)
    hi = mixture_quantile(0.999, m0, m2, duration_s, weights, iterations=30)
    grid = np.linspace(0.0, 1.0, points)
    out = np.empty(m0.shape[0])
    step = max(1, chunk_elements // (points * m0.shape[1]))
    for s in range(0, m0.shape[0], step):
        sl = slice(s, s + step)
        x = lo[sl, None] + (hi - lo)[sl, None] * grid  # (c, G)
        pdf = max_pdf(x[..., None], m0[sl, None, :], m2[sl, None, :], duration_s) @ weights  # (c, G)
        i = np.clip(pdf.argmax(axis=-1), 1, points - 2)
        y0, y1, y2 = (np.take_along_axis(pdf, (i + d)[:, None], axis=-1)[:, 0] for d in (-1, 0, 1))
        denom = y0 - 2 * y1 + y2
        shift = np.where(denom < 0, 0.5 * (y0 - y2) / np.where(denom < 0, denom, -1.0), 0.0)
        out[sl] = lo[sl] + (grid[i] + np.clip(shift, -1, 1) * (grid[1] - grid[0])) * (hi - lo)[sl]
    return out.reshape(shape)


def optimal_heading(headings_deg: np.ndarray, probability: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """β_V* = argmin over the headings of P(max ≥ limit | heading) (thesis eq. 3.13; A5 eq. 16).

    probability: (..., P) over the P headings (last axis). Returns (heading_deg (...), its probability (...)).
    The first heading wins a tie (e.g. P = 0 everywhere)."""
    i = np.argmin(probability, axis=-1)
    return np.asarray(headings_deg)[i], np.take_along_axis(probability, i[..., None], axis=-1)[..., 0]


def direction_weights(beta_deg: np.ndarray, grid_deg: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Linear interpolation on the circle onto an equally spaced direction grid: for angles β (any shape),
    the two grid indices and their weights (i0, i1, w0, w1 as i0, i1, w1 with w0 = 1 − w1)."""
    grid = np.asarray(grid_deg, dtype=float)
    step = 360.0 / grid.size
    if not np.allclose(np.diff(grid), step):
        raise ValueError("the database's wave directions must be equally spaced over 360°")
    u = np.mod(np.asarray(beta_deg, dtype=float) - grid[0], 360.0) / step
    i0 = np.floor(u).astype(int) % grid.size
    return i0, (i0 + 1) % grid.size, u - np.floor(u)


def rotation_operator(dirs_from_deg: np.ndarray, grid_deg: np.ndarray, headings_deg: np.ndarray,
                      offsets_deg: np.ndarray) -> np.ndarray:
    """R (h, p, nD, nb): how a sea on the source's coming-from directions D lands on the database's β grid for
    heading ψ_p and direction hypothesis δ_h: β = ψ − D − 180° + δ (DESIGN §3), split linearly between the two
    neighbouring database directions (so |H|² is interpolated linearly in β, as the tuning's forward model)."""
    beta = (np.asarray(headings_deg, dtype=float)[None, :, None] - np.asarray(dirs_from_deg, dtype=float)[None, None, :]
            - 180.0 + np.asarray(offsets_deg, dtype=float)[:, None, None])  # (h, p, nD)
    i0, i1, f = direction_weights(beta, grid_deg)
    out = np.zeros(beta.shape + (len(grid_deg),))
    np.put_along_axis(out, i0[..., None], (1.0 - f)[..., None], axis=-1)
    # i1 ≠ i0 always (nb ≥ 2), so adding the second weight never overwrites the first
    np.put_along_axis(out, i1[..., None], np.take_along_axis(out, i1[..., None], axis=-1) + f[..., None], axis=-1)
    return out


def heading_response_spectra(power: np.ndarray, waves: np.ndarray, rotation: np.ndarray, d_dir: float) -> np.ndarray:
    """Response spectra of one channel for every loading condition × sea-state hypothesis × heading (A5 eq. 11,
    thesis eq. 3.10): S(ω) = Σ_D |H(ω, β(ψ, D) + δ)|² S_θ(ω, D) ΔD.

    Parameters
    ----------
    power : (nw, n, nb) |H(ω, β_b)|² of the channel for n loading conditions on the database grid [unit²/m²]
    waves : (h, nw, nD) S_θ(ω, D) [m²·s/rad²] of each sea-state hypothesis on the source's directions
    rotation : (h, p, nD, nb) from :func:`rotation_operator`
    d_dir : ΔD [rad] of the source's direction grid

    Returns
    -------
    (nw, n, h, p) response spectra [unit²·s/rad]
    """
    nw, n, nb = power.shape
    h, p = rotation.shape[:2]
    w = np.matmul(waves[:, None], rotation) * d_dir  # (h, p, nw, nb): the sea seen on the β grid at each heading
    w = w.transpose(2, 3, 0, 1).reshape(nw, nb, h * p)
    return np.matmul(power, w).reshape(nw, n, h, p)  # one (n × nb)·(nb × h p) product per frequency
