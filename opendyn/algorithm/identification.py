"""Identification of inertial parameters from measured torques: least squares on the regressor.

Stacking the regressor of N samples (opendyn.algorithm.regressor) gives the overdetermined
linear system

    W pi = T,    W = [Y(q_1, qd_1, qdd_1); ...; Y(q_N, ...)] (N nv, p),  T = [tau_1; ...; tau_N]

Some parameters never move a torque (a first link's inertia about axes other than its joint's)
and others only in fixed combinations (a link's mass with its parent's first moment...), so W
has rank r < p. A rank-revealing QR with column pivoting, W P = Q R, finds them: its first r
pivot columns W_1 are independent, and the others are W_2 = W_1 K with K = R_11^-1 R_12. The
r base parameters (the identifiable combinations) are then

    beta = pi_1 + K pi_2,    W pi = W_1 beta

estimated as beta = R_11^-1 Q_1^T T, with the covariance sigma^2 (R_11^T R_11)^-1 from the
residual's variance sigma^2 = |T - W_1 beta|^2 / (N nv - r) (noise taken as independent and
of one variance on every torque: ordinary least squares, no weighting).
(Gautier and Khalil, "Direct calculation of minimum set of inertial parameters of serial
robots", IEEE T-RA 6(3), 1990; Gautier, "Numerical calculation of the base inertial parameters
of robots", J. Robotic Systems 8(4), 1991.)

A payload carried at a frame {f} adds its ten parameters phi (about {f}'s origin, in its axes)
to the parameters of the frame's body b, moved there by Delta pi_b = L phi (the spatial inertia
Ad_{T_fb}^T G_phi Ad_{T_fb}, linear in phi); with the robot's own parameters known, the torque it
adds is tau - ID(q, qd, qdd) = Y_b L phi, ten parameters by least squares, all identifiable once
the samples move the frame in every direction (Atkeson, An and Hollerbach 1986).

Where qdd (or qd) is not measured: differentiate the sampled q with a smoothing differentiator,
e.g. a Savitzky-Golay filter (scipy.signal.savgol_filter(q, window, order, deriv=2,
delta=dt, axis=0)) or a zero-phase low-pass filter (scipy.signal.filtfilt) of central
differences, and filter the measured torques with the same filter so that both keep the same
band; plain differences of noisy positions amplify the noise by 1/dt^2 and bias the estimate.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy.linalg import qr, solve_triangular

from .._runtime.options import flag
from ..multibody.layout import rigid_body_form
from ..multibody.model import inertia_from_parameters, parameters_of, rigid_body_of
from ..spatial.algebra import inverse_transform, transform_inertia
from . import checks
from .regressor import PARAMETERS_PER_BODY, torque_regressor
from .rnea import inverse_dynamics

PARAMETER_NAMES = ("m", "mcx", "mcy", "mcz", "Ixx", "Ixy", "Iyy", "Ixz", "Iyz", "Izz")
# coefficients of a base parameter's grouping below this, relative to the largest, are shown
# as zero in its text (they are rounding of exact zeros)
SHOWN_RELATIVE = 1e-10


class Identification(NamedTuple):
    """identify's result, for p parameters of which r combinations are identifiable.

    parameters  (r,) the estimated base parameters beta (SI units of the parameters they are
                named after: kg, kg m, kg m^2, and N m s/rad, N m for friction)
    std         (r,) their standard deviations, from the residual
    base        (r, p) beta = base @ pi_full for the full parameter vector pi_full (the model's
                inertial_parameters, then with friction=True the viscous and Coulomb
                coefficients of each joint)
    names       (p,) each full parameter's name, e.g. "Izz[wrist_1_link]", "fv[shoulder_pan_joint]"
    grouping    (r,) each base parameter as text: "Izz[forearm_link] + 0.425 mcx[...]"
    independent (r,) index in pi_full of the parameter each base parameter is named after
    rank        r
    condition_number  cond(W_1) of the independent columns (2-norm; depends on the units)
    residual_rms      the root mean square of T - W_1 beta (N m or N)
    """

    parameters: np.ndarray
    std: np.ndarray
    base: np.ndarray
    names: tuple
    grouping: tuple
    independent: np.ndarray
    rank: int
    condition_number: float
    residual_rms: float


class PayloadEstimate(NamedTuple):
    """identify_payload's result: a rigid payload at a frame {f}, in {f}'s coordinates.

    mass, mass_std              kg
    com, com_std                (3,) its centre of mass in {f} (m)
    inertia, inertia_std        (3, 3) its rotational inertia about its centre of mass, {f}'s
                                axes (kg m^2)
    parameters, parameters_std  (10,) the estimated parameters phi about {f}'s origin, in the
                                order of Model.inertial_parameters
    condition_number, residual_rms  as in Identification
    The standard deviations of com and inertia come from those of phi to first order.
    """

    mass: float
    com: np.ndarray
    inertia: np.ndarray
    mass_std: float
    com_std: np.ndarray
    inertia_std: np.ndarray
    parameters: np.ndarray
    parameters_std: np.ndarray
    condition_number: float
    residual_rms: float


def parameter_names(model, friction=False):
    """Names of the full parameter vector: "m[body]" ... "Izz[body]" for each body (the order
    of Model.inertial_parameters), then with friction "fv[joint]" and "fc[joint]"."""
    names = [f"{p}[{body}]" for body in model.body_names for p in PARAMETER_NAMES]
    if flag(friction, "parameter_names: friction"):
        names += [f"fv[{j}]" for j in model.joint_names] + [f"fc[{j}]" for j in model.joint_names]
    return tuple(names)


def _samples(model, what, q, qd, qdd, tau):
    """Checked samples: (q, qd, qdd, tau) as batches (N, nq), (N, nv); ValueError naming the
    function, the argument and the first sample that is not finite (a dropped measurement)."""
    checks.check_model(model, what)
    arrays, _ = checks.as_states(model, q, ("qd", qd), ("qdd", qdd), ("tau", tau))
    arrays = [a if a.ndim == 2 else a[None] for a in arrays]
    for name, a in zip(("q", "qd", "qdd", "tau"), arrays):
        bad = np.argwhere(~np.isfinite(a))
        if len(bad):
            n, j = bad[0]
            raise ValueError(
                f"{what}: {name} must be finite; sample {n} has {a[n, j]} in column {j} "
                f"({len(bad)} such entries): drop those samples"
            )
    return arrays


class _Fit(NamedTuple):
    """A least-squares fit of T by the independent columns of W: W[:, pivots[:rank]] beta ~ T,
    with W P = Q R (P the pivots), beta's covariance, cond(R_11) and the residual's RMS."""

    beta: np.ndarray
    covariance: np.ndarray
    condition: float
    rms: float
    pivots: np.ndarray
    R: np.ndarray
    rank: int


def _least_squares(W, T, what):
    """The _Fit of T (m,) by W (m, p), from a QR decomposition with column pivoting whose
    diagonal below max(m, p) eps |R_00| counts as zero (numerical rank)."""
    m, p = W.shape
    Q, R, pivots = qr(W, mode="economic", pivoting=True)
    d = np.abs(np.diag(R))
    r = int(np.sum(d > max(m, p) * np.finfo(float).eps * d[0])) if d.size else 0
    if r == 0:
        raise ValueError(
            f"{what}: the samples move no torque with any parameter (the regressor is zero: "
            "e.g. a robot at rest whose joint axes all lie along gravity); give samples with "
            "speeds and accelerations, or poses where gravity acts on the joints"
        )
    if m <= r:
        raise ValueError(
            f"{what}: {m} torque samples (N nv) do not overdetermine the {r} identifiable "
            "parameters; give more samples"
        )
    R_11 = R[:r, :r]
    beta = solve_triangular(R_11, Q[:, :r].T @ T)
    residual = T - W[:, pivots[:r]] @ beta
    sigma2 = float(residual @ residual) / (m - r)
    R_inv = solve_triangular(R_11, np.eye(r))
    return _Fit(
        beta=beta,
        covariance=sigma2 * (R_inv @ R_inv.T),
        condition=float(np.linalg.cond(R_11)) if r else np.inf,
        rms=float(np.sqrt(np.mean(residual**2))),
        pivots=pivots,
        R=R,
        rank=r,
    )


def identify(model, q, qd, qdd, tau, friction=False):
    """The base inertial parameters (and friction) of a robot from measured torques.

    q (N, nq), qd, qdd, tau (N, nv): N samples of the state and the measured joint torques
    (N m or N; for a floating base the first six are the wrench (m_b, f_b) on the base in its
    frame: zero in flight, the contacts' share otherwise, which must then be known or
    measured). friction=True adds each joint's viscous and Coulomb coefficients
    (torque_regressor's friction columns).
    Returns an Identification: the r identifiable combinations beta = base @ pi_full of the
    full parameters (the module docstring has the method), their standard deviations, the
    grouping as text, the condition number and the residual. With noise-free torques of
    enough, varied samples, beta is the model's exactly (to rounding).
    Where qdd is not measured, the module docstring says how to get it: filtered
    differences of q, never plain double differences of noisy positions.
    """
    what = "identify"
    friction = flag(friction, "identify: friction")
    q, qd, qdd, tau = _samples(model, what, q, qd, qdd, tau)
    W = torque_regressor(model, q, qd, qdd, friction=friction)
    fit = _least_squares(W, tau.ravel(), what)
    r, pivots = fit.rank, fit.pivots
    base = np.zeros((r, W.shape[1]))
    base[:, pivots[:r]] = np.eye(r)
    base[:, pivots[r:]] = solve_triangular(fit.R[:r, :r], fit.R[:r, r:])  # K = R_11^-1 R_12
    names = parameter_names(model, friction)
    return Identification(
        parameters=fit.beta,
        std=np.sqrt(np.diag(fit.covariance)),
        base=base,
        names=names,
        grouping=tuple(_grouping(row, names) for row in base),
        independent=np.asarray(pivots[:r]),
        rank=r,
        condition_number=fit.condition,
        residual_rms=fit.rms,
    )


def _grouping(row, names):
    """'a + 0.5 b - 2 c': a base parameter's combination of the full parameters."""
    terms = []
    for k in np.flatnonzero(np.abs(row) > SHOWN_RELATIVE * np.abs(row).max()):
        magnitude = abs(row[k])
        term = names[k] if magnitude == 1.0 else f"{magnitude:.6g} {names[k]}"
        terms.append(("- " if row[k] < 0 else "+ ") + term)
    text = " ".join(terms)
    return text.removeprefix("+ ")


def _payload_map(T_body_frame):
    """L (10, 10): the change of body's parameters per unit of a payload's parameters phi about
    the frame's origin in its axes (Model.with_payload's transform, column by column)."""
    T_frame_body = inverse_transform(T_body_frame)
    L = np.empty((PARAMETERS_PER_BODY, PARAMETERS_PER_BODY))
    for c, unit in enumerate(np.eye(PARAMETERS_PER_BODY)):
        G = transform_inertia(inertia_from_parameters(*rigid_body_of(unit)), T_frame_body)
        L[:, c] = parameters_of(*rigid_body_form(G[None]))[0]
    return L


def _payload_from_parameters(phi, covariance):
    """mass, com, inertia about the centre of mass, and their standard deviations to first
    order, of a payload's parameters phi (10,) about the frame's origin with covariance (10, 10).

    m = phi_0, c = h / m, I_c = I_o - (|h|^2 1 - h h^T) / m  with h = phi_1..3."""
    mass, h, I_o = rigid_body_of(phi)
    com = h / mass
    S = np.dot(h, h) * np.eye(3) - np.outer(h, h)
    inertia = I_o - S / mass
    # the Jacobian of (m, c, I_c entries) with respect to phi
    J = np.zeros((1 + 3 + 6, 10))
    J[0, 0] = 1.0
    J[1:4, 0] = -h / mass**2
    J[1:4, 1:4] = np.eye(3) / mass
    entries = ((0, 0), (0, 1), (1, 1), (0, 2), (1, 2), (2, 2))
    for row, (a, b) in enumerate(entries):
        J[4 + row, 0] = S[a, b] / mass**2
        for k in range(3):
            dS = 2.0 * h[k] * (a == b) - (h[a] * (b == k) + h[b] * (a == k))
            J[4 + row, 1 + k] = -dS / mass
        J[4 + row, 4 + row] = 1.0
    std = np.sqrt(np.diag(J @ covariance @ J.T))
    inertia_std = np.empty((3, 3))
    for row, (a, b) in enumerate(entries):
        inertia_std[a, b] = inertia_std[b, a] = std[4 + row]
    return mass, com, inertia, float(std[0]), std[1:4], inertia_std


# a payload's mass within this many standard deviations of zero is no payload: its centre of
# mass h / m and its inertia about it would be noise divided by noise
MASS_SIGNIFICANCE = 3.0


def _check_mass(mass, mass_std, T, tau, frame, what):
    """Refuse an estimate whose mass is not told apart from zero (|m| <= MASS_SIGNIFICANCE std,
    or below the rounding of the torques): the data hold no payload whose centre of mass and
    inertia could be found."""
    scale = np.finfo(float).eps * len(tau) * max(float(np.abs(tau).max(initial=0.0)), 1.0)
    if abs(mass) > MASS_SIGNIFICANCE * mass_std and np.abs(T).max(initial=0.0) > scale:
        return
    raise ValueError(
        f"{what}: the torques show no payload at frame {frame!r}: tau - ID(model) is "
        f"{np.sqrt(np.mean(T**2)):.3g} N m RMS and the mass comes out {mass:.3g} +- "
        f"{mass_std:.3g} kg, not told apart from zero, so its centre of mass and inertia "
        "cannot be found; check that tau was measured with the payload on, and that `model` is "
        "the robot without it"
    )


def identify_payload(model, frame, q, qd, qdd, tau):
    """Mass, centre of mass and inertia of an unknown rigid payload carried at `frame`.

    model: the robot without the payload (its parameters known: the payload is the difference
    of the robot with and without it). frame: a frame name on a moving body. q (N, nq), qd,
    qdd, tau (N, nv): samples of the state and the measured torques with the payload (N m or
    N). The payload's ten parameters phi about the frame's origin, in its axes, are the least-
    squares solution of tau - inverse_dynamics(model, q, qd, qdd) = Y_b L phi (the module
    docstring has the equations), their standard deviations from the residual.
    Returns a PayloadEstimate: mass (kg), com (3,) (m) and inertia (3, 3) about the centre of
    mass (kg m^2), in the frame's coordinates as Model.with_payload takes them, with standard
    deviations. The estimate is not forced to be physical: a payload too light for the noise
    can come out with a negative moment; look at the standard deviations.
    Where qdd is not measured, differentiate q with a smoothing filter (module docstring).
    ValueError when the samples do not excite the payload's ten parameters, when the torques
    show no payload (its mass within MASS_SIGNIFICANCE standard deviations of zero), or when
    the frame is welded to the fixed world; KeyError for an unknown frame.
    """
    what = "identify_payload"
    q, qd, qdd, tau = _samples(model, what, q, qd, qdd, tau)
    f = model.frames[model.frame_index(frame)]
    if f.body < 0:
        raise ValueError(
            f"{what}: frame {frame!r} of model {model.name!r} is welded to the fixed world, so "
            "a payload on it moves no joint; name a frame of a moving link"
        )
    columns = slice(PARAMETERS_PER_BODY * f.body, PARAMETERS_PER_BODY * (f.body + 1))
    W = torque_regressor(model, q, qd, qdd)[:, columns] @ _payload_map(f.T_body_frame)
    T = (tau - inverse_dynamics(model, q, qd, qdd)).ravel()
    fit = _least_squares(W, T, what)
    pivots = fit.pivots
    if fit.rank < PARAMETERS_PER_BODY:
        unseen = ", ".join(PARAMETER_NAMES[k] for k in sorted(pivots[fit.rank :]))
        raise ValueError(
            f"{what}: the samples do not excite the payload's parameters {unseen} (rank {fit.rank} of "
            "10); move the frame through more varied orientations, speeds and accelerations"
        )
    phi = np.empty(PARAMETERS_PER_BODY)
    phi[pivots] = fit.beta
    cov = np.empty_like(fit.covariance)
    cov[np.ix_(pivots, pivots)] = fit.covariance
    _check_mass(phi[0], np.sqrt(cov[0, 0]), T, tau, frame, what)
    mass, com, inertia, mass_std, com_std, inertia_std = _payload_from_parameters(phi, cov)
    return PayloadEstimate(
        mass=mass,
        com=com,
        inertia=inertia,
        mass_std=mass_std,
        com_std=com_std,
        inertia_std=inertia_std,
        parameters=phi,
        parameters_std=np.sqrt(np.diag(cov)),
        condition_number=fit.condition,
        residual_rms=fit.rms,
    )
