"""Why a run failed, in words: what failed, at which time and step, and the likely cause: an
effect too stiff for the step (its rate times dt past the method's stability limit), the implicit
step's matrix M + dt D + dt^2 K singular while M alone is regular, a singular mass matrix, a
momentum update that does not converge, an adaptive step that underflows, or the forces at the
initial state. Before a run, check_contact_step refuses a fixed explicit step that a contact
makes unstable.
"""

from __future__ import annotations

import numpy as np

from .._runtime.status import Status, decode
from ..algorithm.singular import mass_matrix_with_armature, singular_coordinates
from ..errors import SceneError
from ..multibody.joints import FREE, REVOLUTE
from . import effects, integrators, step
from .effects import registry
from .effects.interface import RatesAt


def failure_message(scene, table, status, t, steps, q, qd, held=None):
    """Why a run stopped at time t after `steps` steps, from the kernel's status and the last
    good state: what failed, and the likely cause. table: the scene's effects.StageTable;
    held: the torque (nv,) a Simulator held over the step, if any (a torque that alone would
    pass max_speed within one step is named as the cause)."""
    model = scene.model
    run = scene.run
    where = f"at t = {t:.6g} s (step {steps})"
    status, _ = decode(status)
    implicit = integrators.INTEGRATORS[run.integrator].kind == integrators.IMPLICIT
    if status == Status.SINGULAR and implicit and _regular_mass_matrix(scene, q):
        stiff = _stiff_effects(_effect_rates(scene, table, q), run.dt, 0.0)[:1]
        return (
            f"the implicit step's matrix M + dt D + dt^2 K became singular {where}, while the "
            "mass matrix M alone is regular: the effects' stiffness and damping swamp M in "
            "float64"
            + (f"; the stiffest: {_describe(stiff, run.dt, lead=False)}" if stiff else "")
            + ". Lower the stiffness, or the step."
        )
    if status == Status.SINGULAR:
        return f"singular mass matrix {where}: {singular_coordinates(model, q, scene.armature)[2]}"
    if status == Status.NO_CONVERGENCE:
        return (
            f"semi-implicit Euler's momentum update did not converge {where}: the step is too "
            f"large for the velocities here (|qd| up to {np.abs(qd).max():.3g}); use a smaller "
            "step"
        )
    if status == Status.STEP_UNDERFLOW:
        # below 1e-14 s even DOPRI5's stability interval (about 3.3 / rate) is left behind
        stiff = _stiff_effects(_effect_rates(scene, table, q), 1e-14, 3.3)
        if stiff:
            cause = (
                f"a step that small is still too large for {_describe(stiff, 1e-14)}, above "
                "3.3. Lower the stiffness, or use integrator implicit_euler"
            )
        elif min(run.rtol, run.atol) < TIGHTEST:
            cause = (
                f"the tolerances (run.rtol = {run.rtol:g}, run.atol = {run.atol:g}) are tighter "
                "than float64 can meet here, where each step rounds at about 1e-15 of the state "
                f"(atol binds every coordinate near zero); loosen them to {TIGHTEST:g} or more"
            )
        else:
            kinks = [name for name in ("contact", "limits") if getattr(scene, name) is not None]
            cause = "The dynamics are likely discontinuous or singular here" + (
                f" ({' or '.join(kinks)} switching on is a kink in the forces: loosen run.rtol "
                f"= {run.rtol:g} and run.atol = {run.atol:g}, or use a fixed step)"
                if kinks
                else ""
            )
        return (
            f"adaptive step underflow {where}: no step down to 1e-14 s met the tolerances. "
            f"Likely cause: {cause}."
        )
    what = {
        Status.Q_NOT_FINITE: "the positions q became non-finite",
        Status.QD_NOT_FINITE: "the velocities qd became non-finite",
        Status.TAU_NOT_FINITE: "a generalized force became non-finite",
        Status.RESULT_NOT_FINITE: "the dynamics overflowed float64 (a force or an acceleration "
        "became inf or NaN at a finite state)",
        Status.DIVERGED: f"a joint velocity exceeded max_speed = {run.max_speed:g}",
    }.get(status, f"the dynamics failed ({status.name})")
    fastest = int(np.argmax(np.abs(qd))) if model.nv else 0
    state = (
        f"the last good state has |qd| up to {np.abs(qd).max():.3g} on coordinate "
        f"{model.v_names[fastest]!r}"
        if model.nv
        else ""
    )
    stiff = [] if implicit else _stiff_effects(_effect_rates(scene, table, q), run.dt, 2.0)
    fixed_explicit = not implicit and not integrators.INTEGRATORS[run.integrator].adaptive
    spin = _fastest_rotation(model, qd) if fixed_explicit else None
    pushed = _torque_too_large(scene, q, held)
    if pushed is not None:
        cause = pushed
    elif stiff:
        cause = _step_too_large(stiff, run.dt, 2.0)
    elif (
        spin is not None
        and spin[1] * run.dt > TURN_PER_STEP
        and (run.integrator != "euler" or steps == 0)  # else Euler's own growth is the cause
    ):
        name, speed = spin
        cause = (
            f"the rotation is too fast for the step: {name!r} turns at {speed:.3g} rad/s, "
            f"{speed * run.dt:.3g} rad per step of {run.dt:g} s, where an explicit step follows "
            f"about {TURN_PER_STEP:g} rad; use a step below {TURN_PER_STEP / speed:.2g} s, "
            "or dopri5"
        )
    elif steps == 0:
        cause = _start_cause(scene, table, q, qd)
    elif run.integrator == "euler":
        cause = (
            "explicit Euler adds energy on every oscillation and diverges; "
            "use semi_implicit_euler, rk4 or a smaller step"
        )
    elif integrators.INTEGRATORS[run.integrator].adaptive:
        cause = "the motion became too fast to follow; check the scene's forces"
    else:
        cause = (
            f"the integrator is unstable at dt = {run.dt:g} s for this motion; "
            "use a smaller step or dopri5"
        )
    return f"simulation stopped {where}: {what}; {state}.\nLikely cause: {cause}."


# tolerances tighter than this ask more of an adaptive step's error estimate than float64 can
# give near a kink: the rounding of a step's stages is about 1e-15 of the state
TIGHTEST = 1e-12
# the most an explicit method's step may turn a joint or a body (rad) before the failure is put
# down to the rotation's speed: RK4 follows a rotation of frequency w only while w dt < 2.8 (its
# stability bound on the imaginary axis) and loses accuracy well before
TURN_PER_STEP = 1.0


def _fastest_rotation(model, qd):
    """(name, |qd|) of the fastest angular velocity coordinate of qd (a revolute joint, or a
    free joint's omega), or None when the model has none."""
    angular = np.zeros(model.nv, dtype=bool)
    for i in range(model.nb):
        if model.jtype[i] == REVOLUTE:
            angular[model.iv[i]] = True
        elif model.jtype[i] == FREE:
            angular[model.iv[i] : model.iv[i] + 3] = True
    if not angular.any():
        return None
    speed = np.where(angular, np.abs(qd), -1.0)
    k = int(np.argmax(speed))
    return model.v_names[k], float(speed[k])


def _start_cause(scene, table, q, qd):
    """Why the very first step failed, when no effect is too stiff for it: the accelerations
    at the initial state, which one step of dt turns into velocities."""
    model, run = scene.model, scene.run
    qdd, tau = np.empty(model.nv), np.empty(model.nv)
    status = step.evaluate(step.scene_data(model, table), 0.0, q, qd, qdd, tau, np.empty(2))
    if status or not np.all(np.isfinite(qdd)):
        return (
            "the dynamics are not finite at the initial state: the forces there (gravity, "
            "wrenches, control) overflow float64; check the scene's parameters"
        )
    j = int(np.argmax(np.abs(qdd)))
    reach = abs(qdd[j]) * (run.dt if not integrators.INTEGRATORS[run.integrator].adaptive else 1.0)
    return (
        f"the forces at the initial state: they accelerate {model.v_names[j]!r} at "
        f"{qdd[j]:.3g} (rad or m)/s^2, "
        + (
            f"so one step of {run.dt:g} s already reaches {reach:.3g}, beyond run.max_speed = "
            f"{run.max_speed:g}"
            if reach > run.max_speed
            else "and the first step does not survive them"
        )
        + "; check the scene's forces (gravity, wrenches, control gains) and initial state"
    )


def _torque_too_large(scene, q, held):
    """The cause when the held torque alone, qdd = (M + diag(armature))^-1 tau_held at q,
    would take a coordinate past max_speed within one step dt; else None."""
    if held is None or not np.any(held):
        return None
    M = _scene_mass_matrix(scene, q)
    try:
        qdd = np.linalg.solve(M, held) if M is not None else None
    except np.linalg.LinAlgError:
        qdd = None
    run, model = scene.run, scene.model
    if qdd is None or not np.abs(qdd).max() * run.dt > run.max_speed:
        return None
    j, k = int(np.argmax(np.abs(held))), int(np.argmax(np.abs(qdd)))
    return (
        f"the torque the step was given (|tau| up to {abs(held[j]):.3g} on "
        f"{model.v_names[j]!r}) accelerates {model.v_names[k]!r} at {abs(qdd[k]):.3g} per s^2: "
        f"{abs(qdd[k]) * run.dt:.3g} per s within one step of {run.dt:g} s, past max_speed = "
        f"{run.max_speed:g}; check the torque (its units, its gains)"
    )


def _scene_mass_matrix(scene, q):
    """M(q) with the scene's armature, or None where it cannot be computed."""
    try:
        return mass_matrix_with_armature(scene.model, q, scene.armature)
    except ValueError:
        return None


def _regular_mass_matrix(scene, q):
    """Whether M(q) (with the scene's armature) is positive definite to float64."""
    M = _scene_mass_matrix(scene, q)
    if M is None:
        return False
    try:
        np.linalg.cholesky(M)
    except np.linalg.LinAlgError:
        return False
    return True


def _effect_rates(scene, table, q):
    """[(name, rates, where)]: the rates at q of the effects the scene names (each effect
    module's `rates`): for each joint, the natural frequency w = sqrt(k / M_jj) of its springs
    (limits, PD) and the rate d / M_jj of its dampers; for each contact point, those of the
    contact's spring and damper over the point's apparent mass, and of friction near zero slip.
    Explicit methods need dt x rate below about 2 (Euler) to 2.8 (RK4). Empty where M(q) cannot
    be computed."""
    model = scene.model
    M = _scene_mass_matrix(scene, q) if model.nv else None
    if M is None:
        return []
    at = _rates_at(scene, table, q, np.diag(M)[model.v_index])  # the joints' entries
    candidates = []
    for effect in registry.stages():
        record = effect.record(scene)
        if effect.rates is not None and record is not None:
            candidates += effect.rates(record, at)
    return candidates


def _rates_at(scene, table, q, joint_mass):
    """The RatesAt of the scene at q: solve(tau) = M^-1 tau is the scene's own forward dynamics
    at rest, without gravity and constraints, so that the rates compile nothing the run does
    not. table: the scene's effects.StageTable."""
    from ..algorithm.forward import method_switches

    model = scene.model
    q = np.array(q, dtype=np.float64)  # writable, as in the run: no new specialisation
    unconstrained = step.scene_data(model, table)._replace(
        constraints=None, method=method_switches(model, table.method), loads=np.zeros((1, 6))
    )
    at_rest, qdd = np.zeros(model.nv), np.empty(model.nv)

    def solve(tau):
        status = step.dynamics(unconstrained, q, at_rest, tau, qdd)
        return None if status else qdd.copy()

    return RatesAt(scene, q, joint_mass, solve)


def _stiff_effects(candidates, dt, limit):
    """[(rate, name, where)] of the candidates (name, rates, where) whose largest rate has
    dt x rate >= limit (and is not zero), the stiffest first."""
    stiff = []
    for name, rate, where in candidates:
        j = int(np.argmax(rate))
        if rate[j] > 0 and rate[j] * dt >= limit:
            stiff.append((float(rate[j]), name, where[j]))
    return sorted(stiff, reverse=True)


def _step_too_large(stiff, dt, limit):
    """The sentence for an explicit step past the stability `limit` of dt x rate of the stiff
    effects (_stiff_effects), with the step that suits them all."""
    return (
        f"the step is too large for {_describe(stiff, dt)}, above {limit:g}. Use dt below "
        f"{limit / stiff[0][0]:.2g} s, or integrator implicit_euler"
    )


def _describe(stiff, dt, lead=True):
    """The stiff effects of _stiff_effects as a phrase naming each, with its rate and dt x rate;
    lead: open with "a stiff effect: " or "stiff effects: "."""
    named = "; ".join(
        f"{name} on {where} has rate {rate:.3g} 1/s (dt x rate = {rate * dt:.3g})"
        for rate, name, where in stiff
    )
    if not lead:
        return named
    return ("a stiff effect: " if len(stiff) == 1 else "stiff effects: ") + named


def check_contact_step(scene, table):
    """Refuse a fixed-step explicit run whose step the contact makes unstable: at q0, the
    contact's rates (effects.contact.rates) times dt must stay inside the method's stability
    interval on the real and imaginary axes (RK4 about 2.8, Euler and semi-implicit Euler 2).
    Beyond it a contact does not always blow up (the clamp f_n >= 0 and friction's saturation
    bound it): the feet chatter and the run returns nonsense, so it is refused before it
    starts.
    table: the scene's effects.StageTable. Raises SceneError naming the contact point, the
    rate and the step that suits it."""
    run = scene.run
    integ = integrators.INTEGRATORS[run.integrator]
    compliant = effects.contact.record(scene) or effects.geometry_contact.record(scene)
    if compliant is None or integ.adaptive or integ.kind == integrators.IMPLICIT:
        return
    limit = 2.8 if integ.order == 4 else 2.0
    module = effects.contact if effects.contact.record(scene) else effects.geometry_contact
    rates = module.rates(scene.contact, _rates_at(scene, table, scene.q0, None))
    stiff = _stiff_effects(rates, run.dt, limit)
    if stiff:
        raise SceneError(
            f"{scene.source}: run.dt: {run.integrator} at dt = {run.dt:g} s is unstable for "
            f"the contact at the initial state: {_step_too_large(stiff, run.dt, limit)}"
        )
