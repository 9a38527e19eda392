"""Andrews' squeezing mechanism in its seven angles: this project's own solution of the planar problem,
the second source beside the IVP test set's reference (``models/andrews_squeezer.toml``).

The mechanism and its data are those of Hairer & Wanner (1996), *Solving Ordinary Differential Equations
II*, §VII.7 (after Giles 1978 and Manning 1981; Schiehlen 1990), and of the IVP test set (Lioen &
de Swart 1998; Mazzia & Magherini 2008, problem "andrews"): seven rigid bodies K1 … K7 moving in a
plane, joined by ten revolute joints (three closed loops through the point E), a spring between the
point D of K3 and the fixed point C, a constant moment ``mom`` driving K1.  The angles
``q = (β, Θ, γ, Φ, δ, Ω, ε)`` [rad] are: β of K1 about O, Θ of K2 relative to K1, γ of K3 about B, δ of
K5 about A, Φ of K4 relative to K5, ε of K7 about A, Ω of K6 relative to K7.

Nothing below is transcribed from the published mass matrix or force vector: every point of every body
is written as ``p(q) = p0 + Σ a u(c·q + φ)`` (``u(θ) = (cos θ, sin θ)``), and the equations of motion
follow by Lagrange's equations from the kinetic energy ``Σ ½ m |ċ|² + ½ I θ̇²`` of the bodies' centres
of mass c and angles θ; :func:`mass_matrix` is compared with Hairer & Wanner's M(q) in the tests.  The
index-1 form ``[M Gᵀ; G 0] [q̈; λ] = [Q; −ġ_q q̇]`` is integrated by scipy's DOP853 (Dormand & Prince
1980) at ``rtol = 1e-12`` from the test set's consistent initial angles at rest.
"""

from __future__ import annotations

import numpy as np

PARAMETERS = dict(m1=0.04325, m2=0.00365, m3=0.02373, m4=0.00706, m5=0.07050, m6=0.00706, m7=0.05498,
                  xa=-0.06934, ya=-0.00227, xb=-0.03635, yb=0.03273, xc=0.014, yc=0.072, c0=4530.0,
                  i1=2.194e-6, i2=4.410e-7, i3=5.255e-6, i4=5.667e-7, i5=1.169e-5, i6=5.667e-7, i7=1.912e-5,
                  d=28e-3, da=115e-4, e=2e-2, ea=1421e-5, rr=7e-3, ra=92e-5, l0=7785e-5,
                  ss=35e-3, sa=1874e-5, sb=1043e-5, sc=18e-3, sd=2e-2, ta=2308e-5, tb=916e-5,
                  u=4e-2, ua=1228e-5, ub=449e-5, zf=2e-2, zt=4e-2, fa=1421e-5, mom=33e-3)
"""The mechanism's data (Hairer & Wanner 1996, §VII.7, Table 7.1; the IVP test set): masses [kg], moments
of inertia about the centres of mass [kg m²], lengths and coordinates [m], spring stiffness c0 [N/m] and
rest length l0 [m], driving moment mom [N m]."""

Q0 = np.array([-0.0617138900142764496358948458001, 0.0, 0.455279819163070380255912382449,
               0.222668390165885884674473185609, 0.487364979543842550225598953530,
               -0.222668390165885884674473185609, 1.23054744454982119249735015568])
"""Consistent initial angles (β, Θ, γ, Φ, δ, Ω, ε) [rad] of the test set, the mechanism at rest at t = 0."""

REFERENCE = np.array([0.1581077119629904e2, -0.1575637105984298e2, 0.4082224013073101e-1, -0.5347301163226948,
                      0.5244099658805304, 0.5347301163226948, 0.1048080741042263e1])
"""The angles at t = 0.03 s of the IVP test set (Mazzia & Magherini 2008, "andrews"; computed with PSIDE at
rtol = atol = 1e-14)."""

NAMES = ("β", "Θ", "γ", "Φ", "δ", "Ω", "ε")
T_END = 0.03

_B, _TH, _G, _PH, _D, _OM, _EP = np.eye(7)
_QUARTER = 0.5 * np.pi


def points(p=PARAMETERS) -> dict:
    """Every point of the mechanism as ``(p0, [(a, c, φ), …])``: ``p(q) = p0 + Σ a u(c·q + φ)`` [m].

    Bodies' centres of mass ``K1`` … ``K7`` (K3, K5, K7 turn about a fixed point: only their distance
    from it enters the dynamics, the direction is this module's choice), joint points ``P`` (K1–K2),
    ``F`` (K4–K5), ``G`` (K6–K7), ``E`` reached along each of its four bodies (``E2``, ``E3``, ``E4``,
    ``E6``: the loops close where they coincide), the spring's end ``D`` on K3.
    """
    O, A, B = np.zeros(2), np.array([p["xa"], p["ya"]]), np.array([p["xb"], p["yb"]])
    P = [(p["rr"], _B, 0.0)]
    F = [(p["zt"], _D, 0.0)]
    G = [(p["u"], _EP, -_QUARTER)]
    return {
        "K1": (O, [(p["ra"], _B, 0.0)]),
        "K2": (O, P + [(-p["da"], _B + _TH, 0.0)]),
        "K3": (B, [(p["sa"], _G, -_QUARTER), (p["sb"], _G, 0.0)]),
        "K4": (A, F + [(p["e"] - p["ea"], _PH + _D, -_QUARTER)]),
        "K5": (A, [(p["ta"], _D, 0.0), (p["tb"], _D, _QUARTER)]),
        "K6": (A, G + [(p["zf"] - p["fa"], _OM + _EP, 0.0)]),
        "K7": (A, [(p["ua"], _EP, -_QUARTER), (p["ub"], _EP, 0.0)]),
        "O": (O, []), "A": (A, []), "B": (B, []), "P": (O, P), "F": (A, F), "G": (A, G),
        "E2": (O, P + [(-p["d"], _B + _TH, 0.0)]),
        "E3": (B, [(p["ss"], _G, -_QUARTER)]),
        "E4": (A, F + [(p["e"], _PH + _D, -_QUARTER)]),
        "E6": (A, G + [(p["zf"], _OM + _EP, 0.0)]),
        "D": (B, [(p["sd"], _G, 0.0), (p["sc"], _G, -_QUARTER)]),
    }


ANGLES = {"K1": _B, "K2": _B + _TH, "K3": _G, "K4": _PH + _D, "K5": _D, "K6": _OM + _EP, "K7": _EP}
"""Each body's absolute angle about z as a combination of q."""


def kinematics(point, q, qd):
    """Position (2,), Jacobian ∂p/∂q (2, 7) and the velocity-quadratic part of p̈, ``Σ −a (c·q̇)² u`` (2,)."""
    p0, terms = point
    x, J, quad = np.array(p0, dtype=float), np.zeros((2, 7)), np.zeros(2)
    for a, c, phi in terms:
        th = c @ q + phi
        u, n = np.array([np.cos(th), np.sin(th)]), np.array([-np.sin(th), np.cos(th)])
        x += a * u
        J += a * np.outer(n, c)
        quad -= a * (c @ qd) ** 2 * u
    return x, J, quad


def mass_matrix(q, p=PARAMETERS) -> np.ndarray:
    """M(q) = Σ m Jᵀ J + I e eᵀ over the bodies (J the Jacobian of the centre of mass, e its angle) [kg m²]."""
    pts = points(p)
    M = np.zeros((7, 7))
    for k in range(1, 8):
        _, J, _ = kinematics(pts[f"K{k}"], q, np.zeros(7))
        e = ANGLES[f"K{k}"]
        M += p[f"m{k}"] * J.T @ J + p[f"i{k}"] * np.outer(e, e)
    return M


def _system(q, qd, p, pts):
    """M, the generalised forces Q (moment, spring, velocity-quadratic inertia terms), G and −(Ġ q̇)."""
    M, Q = np.zeros((7, 7)), np.zeros(7)
    for k in range(1, 8):
        _, J, quad = kinematics(pts[f"K{k}"], q, qd)
        e = ANGLES[f"K{k}"]
        M += p[f"m{k}"] * J.T @ J + p[f"i{k}"] * np.outer(e, e)
        Q -= p[f"m{k}"] * J.T @ quad
    xd, Jd, _ = kinematics(pts["D"], q, qd)
    r = xd - np.array([p["xc"], p["yc"]])
    length = np.hypot(*r)
    Q += Jd.T @ (-p["c0"] * (length - p["l0"]) * r / length)
    Q[0] += p["mom"]
    e2 = kinematics(pts["E2"], q, qd)
    G, gam = np.zeros((6, 7)), np.zeros(6)
    for row, other in enumerate(("E3", "E4", "E6")):
        eo = kinematics(pts[other], q, qd)
        G[2 * row:2 * row + 2] = e2[1] - eo[1]
        gam[2 * row:2 * row + 2] = -(e2[2] - eo[2])
    return M, Q, G, gam


def constraints(q, p=PARAMETERS) -> np.ndarray:
    """The six loop-closure equations g(q) = (E2 − E3, E2 − E4, E2 − E6) [m]."""
    pts = points(p)
    e2 = kinematics(pts["E2"], q, np.zeros(7))[0]
    return np.concatenate([e2 - kinematics(pts[k], q, np.zeros(7))[0] for k in ("E3", "E4", "E6")])


def accelerations(q, qd, p=PARAMETERS):
    """q̈ [rad/s²] and the multipliers λ [N] of the index-1 form ``[M Gᵀ; G 0] [q̈; λ] = [Q; −Ġ q̇]``."""
    M, Q, G, gam = _system(q, qd, p, points(p))
    K = np.block([[M, G.T], [G, np.zeros((6, 6))]])
    sol = np.linalg.solve(K, np.concatenate([Q, gam]))
    return sol[:7], sol[7:]


def solve(t_end: float = T_END, rtol: float = 1e-12, atol: float = 1e-13, t_eval=None, p=PARAMETERS):
    """The angles from :data:`Q0` at rest: scipy ``solve_ivp`` (DOP853) of the index-1 form; returns the
    solution object (``y[:7]`` the angles [rad], ``y[7:]`` their rates [rad/s])."""
    from scipy.integrate import solve_ivp

    def rhs(t, y):
        return np.concatenate([y[7:], accelerations(y[:7], y[7:], p)[0]])

    return solve_ivp(rhs, (0.0, t_end), np.concatenate([Q0, np.zeros(7)]), method="DOP853", rtol=rtol, atol=atol,
                     t_eval=t_eval)


OBSERVABLES = ("angle.z:K1", "angle.z:K2,K1", "angle.z:K3", "angle.z:K4,K5", "angle.z:K5", "angle.z:K6,K7",
               "angle.z:K7")
"""The seven angles' changes since t = 0 in the deck ``models/andrews_squeezer.toml`` (bodies K1 … K7)."""


def angles(results) -> np.ndarray:
    """The angles (β, Θ, γ, Φ, δ, Ω, ε) [rad] of a run of the deck at its outputs, (n, 7): the
    ``angle.z`` observables (unwrapped in time) plus :data:`Q0`."""
    from reference.observables import parse

    return np.array([parse(text, results).evaluate(results) for text in OBSERVABLES]).T + Q0
