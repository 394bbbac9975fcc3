"""Import a WAMIT-format hydro database (PREFIX.1, PREFIX.3, PREFIX.hst, optional PREFIX.frc).

File formats (WAMIT manual ch. 4-5, single body, ULEN = L = `length_scale`, wave amplitude A = 1):

- ``.1``  ``PER I J Ā B̄`` with Ā = A/(ρL^k), B̄ = B/(ρωL^k), k = 3, 4, 5 for translation-translation,
  translation-rotation, rotation-rotation. PER = -1 is ω = 0 (only Ā; dropped here), PER = 0 is ω = ∞
  (only Ā; becomes `added_mass_inf`). I is the force (influenced) mode, J the motion (radiating) mode:
  A_ij - B_ij/(iω) = ρ∬ n_i φ_j dS. Entries WAMIT leaves out are zero.
- ``.3``  ``PER BETA I |X̄| phase Re(X̄) Im(X̄)``, X̄ = X/(ρgA L^m), m = 2 forces, 3 moments; BETA in degrees,
  the direction the waves travel towards, from +x (Capytaine's `wave_direction`). WAMIT's time factor is
  e^{+iωt}, seatune's (Capytaine's) e^{-iωt}: X = conj(X̄_WAMIT) ρgL^m. Re and Im are used (more digits
  than modulus and phase).
- ``.hst`` ``I J C̄`` with C̄ = C/(ρgL^k), k = 2 for (3,3), 3 for (3,4) and (3,5), 4 for the rotation pairs.
  It is the *total* restoring (buoyancy and weight, about the origin); the weight terms are removed with
  the mass and centre of gravity it was computed for (:func:`seatune.io.capytaine_import.weight_stiffness`).
- ``.frc`` force control file. Alternative form 1: header, IOPTN(1-9), VCG, 3x3 XPRDCT (radii of
  gyration), NBETAH, NFIELD: it gives z_g only. Alternative form 2: header, IOPTN, RHO, XCG YCG ZCG,
  IMASS, [6x6 mass matrix], IDAMP, [...], ISTIF, [...], NBETAH, NFIELD: mass = M11 and the full COG.
  Trailing labels after the numbers on a line are ignored. Values the .frc lacks come from the `mass` and
  `center_of_mass` arguments.

The first column is read as a period in seconds (WAMIT's default IPEROUT = 1). The displaced volume is
mass/ρ (free floating); the centre of buoyancy's x and y follow from the buoyancy stiffness
(C_b46 = -ρgV x_b, C_b56 = -ρgV y_b), its z cannot be recovered from these files and is NaN.

Capytaine's exporter (capytaine.io.wamit, 3.0) writes these files with 7 significant digits, L = 1 and
conjugated forces, but writes the .1 file with I = radiating and J = influenced dof (the transpose of
WAMIT's definition); its .hst uses k + 1 (3, 4, 5), which makes no difference at L = 1.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from seatune.errors import UserError
from seatune.io.capytaine_import import center_of_buoyancy_from_stiffness, weight_stiffness
from seatune.physics.hydro import DirectionGridError, HydroDatabase

_ROT = np.arange(6) >= 3
_K_RADIATION = 3 + _ROT[:, None] + _ROT[None, :]  # Ā = A/(ρ L^k)
_K_HST = 2 + _ROT[:, None] + _ROT[None, :]  # C̄ = C/(ρ g L^k)
_M_EXCITATION = 2 + _ROT  # X̄ = X/(ρ g A L^m)


def read_wamit(prefix, *, draft: float, rho: float = 1025.0, g: float = 9.81, length_scale: float = 1.0,
               mass: float | None = None, center_of_mass=None, water_depth: float = np.inf) -> HydroDatabase:
    """Hydro database of one draft from PREFIX.1, PREFIX.3, PREFIX.hst (and PREFIX.frc when present).

    `mass` [kg] and `center_of_mass` (x, y, z) [m, body frame: origin on the waterline] are the loading the
    .hst restoring was computed for; a .frc file overrides them where it gives them.
    """
    prefix = str(prefix)
    paths = {ext: Path(prefix + ext) for ext in (".1", ".3", ".hst", ".frc")}
    for ext in (".1", ".3", ".hst"):
        if not paths[ext].exists():
            raise UserError(str(paths[ext]), None, "file not found (a WAMIT database needs PREFIX.1, .3 and .hst)")
    L = float(length_scale)

    periods, a_bar, b_bar, a_inf_bar = _read_1(paths[".1"])
    x_periods, betas_deg, x_bar = _read_3(paths[".3"])
    c_bar = _read_hst(paths[".hst"])

    # one frequency grid: the .3 periods must be the .1 periods
    index = _match(x_periods, periods)
    if (index < 0).any() or len(x_periods) != len(periods):
        missing = [p for p in periods if not np.isclose(x_periods, p, rtol=1e-6, atol=0).any()]
        extra = x_periods[index < 0]
        what = (f"period {missing[0]:g} s of {paths['.1'].name} is missing" if missing
                else f"period {extra[0]:g} s is not in {paths['.1'].name}")
        raise UserError(str(paths[".3"]), None, f"{what}; the two files must have the same periods")
    x_bar = x_bar[np.argsort(index)]

    omega = 2 * np.pi / periods
    order = np.argsort(omega)
    omega, a_bar, b_bar, x_bar = omega[order], a_bar[order], b_bar[order], x_bar[order]

    attrs: dict = {"source": "WAMIT", "source_prefix": prefix}
    scale_a = rho * L ** _K_RADIATION
    added_mass = a_bar * scale_a
    damping = b_bar * scale_a * omega[:, None, None]
    if a_inf_bar is None:
        added_mass_inf = added_mass[-1].copy()
        attrs["added_mass_inf"] = "approximated by highest frequency"
    else:
        added_mass_inf = a_inf_bar * scale_a
    excitation = np.conj(x_bar) * (rho * g * L ** _M_EXCITATION)
    stiffness = c_bar * (rho * g * L ** _K_HST)

    m, cog, origin = _mass_and_cog(paths, rho, mass, center_of_mass)
    buoyancy = stiffness - weight_stiffness(m, cog, g)
    volume = m / rho
    attrs.update(weight_terms_from=origin, weight_terms_mass=m, weight_terms_center_of_mass=np.asarray(cog),
                 disp_volume="mass / rho (free floating)",
                 center_of_buoyancy_z="unknown: not recoverable from the WAMIT .hst file")
    try:
        return HydroDatabase(
            drafts=np.array([float(draft)]), omega=omega, wave_direction=np.deg2rad(betas_deg),
            added_mass=added_mass[None], radiation_damping=damping[None], added_mass_inf=added_mass_inf[None],
            excitation_force=excitation[None], buoyancy_stiffness=buoyancy[None], disp_volume=np.array([volume]),
            center_of_buoyancy=center_of_buoyancy_from_stiffness(buoyancy, volume, rho, g)[None],
            rho=float(rho), g=float(g), water_depth=float(water_depth), attrs=attrs,
        )
    except DirectionGridError as err:
        raise UserError(str(paths[".3"]), "BETA", str(err)) from None


# ----------------------------------------------------------------------------------------------------------------------


def _lines(path: Path):
    """(line number, tokens) of the non-blank lines."""
    try:
        text = path.read_text(errors="replace")
    except OSError as err:
        raise UserError(str(path), None, f"cannot be read ({err})") from None
    for n, line in enumerate(text.splitlines(), start=1):
        tokens = line.split()
        if tokens:
            yield n, tokens


def _number(tok: str, path: Path, n: int) -> float:
    try:
        val = float(tok.replace("D", "E").replace("d", "e"))  # Fortran double-precision exponents
    except ValueError:
        raise UserError(str(path), f"line {n}", f"expected a number, got {tok!r}") from None
    if not np.isfinite(val):
        raise UserError(str(path), f"line {n}", f"non-finite value {tok!r}")
    return val


def _dof(tok: str, path: Path, n: int) -> int:
    val = _number(tok, path, n)
    if val != int(val) or not 1 <= val <= 6:
        more = " (multi-body and generalised modes are not supported)" if val == int(val) and val > 6 else ""
        raise UserError(str(path), f"line {n}", f"mode index {tok!r} is not 1..6{more}")
    return int(val) - 1


def _fields(tokens: list[str], counts: tuple[int, ...], path: Path, n: int, layout: str) -> None:
    if len(tokens) not in counts:
        raise UserError(str(path), f"line {n}", f"expected {layout}, got {len(tokens)} fields")


def _read_1(path: Path):
    """Periods (ascending as found), Ā and B̄ (nper, 6, 6) with [influenced, radiating], Ā(∞) or None."""
    regular: dict[float, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
    special: dict[float, tuple[np.ndarray, np.ndarray]] = {}
    for n, tokens in _lines(path):
        _fields(tokens, (4, 5), path, n, "PER I J A [B]")
        per = _number(tokens[0], path, n)
        i, j = _dof(tokens[1], path, n), _dof(tokens[2], path, n)
        a = _number(tokens[3], path, n)
        if per > 0:
            _fields(tokens, (5,), path, n, "PER I J A B for a period > 0")
            a_mat, b_mat, seen = regular.setdefault(per, (np.zeros((6, 6)), np.zeros((6, 6)), np.zeros((6, 6), bool)))
            b_mat[i, j] = _number(tokens[4], path, n)
        elif per == 0.0 or per == -1.0:
            a_mat, seen = special.setdefault(per, (np.zeros((6, 6)), np.zeros((6, 6), bool)))
        else:
            raise UserError(str(path), f"line {n}", f"period {tokens[0]} (only > 0, 0 for ω = ∞, -1 for ω = 0)")
        if seen[i, j]:
            raise UserError(str(path), f"line {n}", f"second entry for I={i + 1} J={j + 1} at PER={tokens[0]}")
        seen[i, j] = True
        a_mat[i, j] = a
    if not regular:
        raise UserError(str(path), None, "no added mass and damping at a finite, non-zero frequency")
    periods = np.array(sorted(regular))
    a_bar = np.stack([regular[p][0] for p in periods])
    b_bar = np.stack([regular[p][1] for p in periods])
    a_inf = special[0.0][0] if 0.0 in special else None
    return periods, a_bar, b_bar, a_inf


def _read_3(path: Path):
    """Periods (ascending), headings [deg] (ascending) and X̄ (nper, nbeta, 6) as written (WAMIT e^{+iωt})."""
    values: dict[tuple[float, float], np.ndarray] = {}
    seen: set[tuple[float, float, int]] = set()
    for n, tokens in _lines(path):
        _fields(tokens, (7,), path, n, "PER BETA I |X| phase Re Im")
        per, beta = _number(tokens[0], path, n), _number(tokens[1], path, n)
        i = _dof(tokens[2], path, n)
        re, im = _number(tokens[5], path, n), _number(tokens[6], path, n)
        if per <= 0:
            raise UserError(str(path), f"line {n}", f"period {tokens[0]} is not > 0")
        if (per, beta, i) in seen:
            raise UserError(str(path), f"line {n}", f"second entry for PER={tokens[0]} BETA={tokens[1]} I={i + 1}")
        seen.add((per, beta, i))
        values.setdefault((per, beta), np.zeros(6, complex))[i] = complex(re, im)
    if not values:
        raise UserError(str(path), None, "no excitation force lines")
    periods = np.array(sorted({p for p, _ in values}))
    betas = np.array(sorted({b for _, b in values}))
    x_bar = np.zeros((len(periods), len(betas), 6), complex)
    for ip, p in enumerate(periods):
        for ib, b in enumerate(betas):
            if (p, b) not in values:
                raise UserError(str(path), None, f"no excitation for PER={p:g} s, BETA={b:g} deg (incomplete grid)")
            x_bar[ip, ib] = values[(p, b)]
    return periods, betas, x_bar


def _read_hst(path: Path) -> np.ndarray:
    c_bar = np.zeros((6, 6))
    seen = np.zeros((6, 6), bool)
    for n, tokens in _lines(path):
        _fields(tokens, (3,), path, n, "I J C")
        i, j = _dof(tokens[0], path, n), _dof(tokens[1], path, n)
        if seen[i, j]:
            raise UserError(str(path), f"line {n}", f"second entry for I={i + 1} J={j + 1}")
        seen[i, j] = True
        c_bar[i, j] = _number(tokens[2], path, n)
    if not seen.any():
        raise UserError(str(path), None, "no hydrostatic restoring coefficients")
    return c_bar


def _match(values: np.ndarray, grid: np.ndarray) -> np.ndarray:
    """Index in `grid` of each value (relative tolerance 1e-6), -1 when absent."""
    out = np.full(len(values), -1)
    for k, v in enumerate(values):
        hit = np.flatnonzero(np.isclose(grid, v, rtol=1e-6, atol=0))
        if hit.size:
            out[k] = hit[0]
    return out


def _read_frc(path: Path) -> dict:
    """rho (or None), COG with NaN where the form does not give it, mass (or None), form."""
    rows = []  # (line number, leading numbers)
    for k, (n, tokens) in enumerate(_lines(path)):
        if k == 0:
            continue  # header
        nums = []
        for tok in tokens:
            try:
                nums.append(float(tok.replace("D", "E").replace("d", "e")))
            except ValueError:
                break  # trailing label such as "VCG" or "IOPTN(1-9)"
        rows.append((n, nums))
    need = "a WAMIT force control file (alternative form 1 or 2)"
    if len(rows) < 5 or any(not nums for _, nums in rows[:4]):
        raise UserError(str(path), None, f"too short or not {need}")
    (n_io, ioptn), (n3, l3), (n4, l4), (n5, l5) = rows[:4]
    if len(ioptn) < 1:
        raise UserError(str(path), f"line {n_io}", "expected IOPTN(1-9)")
    if len(l4) < 3:
        raise UserError(str(path), f"line {n4}", f"expected three numbers ({need})")
    if len(l5) >= 3:  # form 1: VCG, XPRDCT rows
        return {"form": 1, "rho": None, "cog": np.array([np.nan, np.nan, l3[0]]), "mass": None}
    # form 2: RHO, XCG YCG ZCG, IMASS, [6 x 6 mass]
    imass = l5[0]
    if imass not in (0, 1):
        raise UserError(str(path), f"line {n5}", f"IMASS must be 0 or 1, got {imass:g}")
    mass = None
    if imass == 1:
        if len(rows) < 10:
            raise UserError(str(path), None, "IMASS = 1 but the 6 x 6 mass matrix is incomplete")
        matrix = []
        for n, nums in rows[4:10]:
            if len(nums) < 6:
                raise UserError(str(path), f"line {n}", "expected a row of six mass matrix coefficients")
            matrix.append(nums[:6])
        mass = float(matrix[0][0])
        if not mass > 0:
            raise UserError(str(path), f"line {rows[4][0]}", f"mass M11 = {mass:g} is not positive")
    if not l3[0] > 0:
        raise UserError(str(path), f"line {n3}", f"RHO = {l3[0]:g} is not positive")
    return {"form": 2, "rho": l3[0], "cog": np.array(l4[:3], dtype=float), "mass": mass}


def _mass_and_cog(paths: dict, rho: float, mass, center_of_mass) -> tuple[float, np.ndarray, str]:
    frc = _read_frc(paths[".frc"]) if paths[".frc"].exists() else None
    arg_cog = None if center_of_mass is None else np.asarray(center_of_mass, dtype=float).reshape(3)
    if frc is None:
        m, cog, origin = mass, arg_cog, "arguments"
    else:
        if frc["rho"] is not None and not np.isclose(frc["rho"], rho, rtol=1e-9):
            raise UserError(str(paths[".frc"]), "RHO", f"is {frc['rho']:g} but rho={rho:g} was given; pass "
                                                       f"rho={frc['rho']:g} (or fix the file)")
        m = frc["mass"] if frc["mass"] is not None else mass
        cog = frc["cog"].copy()
        if np.isnan(cog).any() and arg_cog is not None:
            cog[np.isnan(cog)] = arg_cog[np.isnan(cog)]
        from_frc = (["mass"] if frc["mass"] is not None else []) + (
            ["COG"] if not np.isnan(frc["cog"]).any() else ["z_g"])
        origin = f"{paths['.frc'].name} ({' and '.join(from_frc)})"
        if from_frc != ["mass", "COG"]:
            origin += " and arguments"
    if m is None or cog is None or np.isnan(cog).any() or not np.isfinite(float(m)):
        frc_note = f" ({paths['.frc'].name} does not give them all)" if frc is not None else ""
        raise UserError(str(paths[".hst"]), None,
                        "mass and centre of gravity are needed to separate the weight terms from the hydrostatic "
                        f"restoring: give a .frc file or pass mass= and center_of_mass={frc_note}")
    if not float(m) > 0:
        raise UserError(str(paths[".hst"]), None, f"mass {float(m):g} kg is not positive")
    return float(m), cog, origin
