"""Chung & Ooi (2011) benchmark: parameters, closed forms and simulation drivers.

Shared by ``tests/validation/test_chung_ooi.py`` (the checks) and
``docs/validation/make_figures.py`` (the figures and the error table), so that both run exactly
the same cases. No pytest and no matplotlib here.

Source of the cases: Y. C. Chung and J. Y. Ooi, "Benchmark tests for verifying discrete element
modelling codes at particle impact level", Granular Matter 13 (2011) 643-656, with the parameters
as the LIGGGHTS-PFM decks (examples/LIGGGHTS/PFM/tests/contact_models/chung/test01..08) implement
them (summarised in shared/research/validation.md, section 5.2).

Closed forms
------------
Hertz (Johnson 1985, Contact Mechanics, sections 4.2 and 11.4), for an elastic impact at normal
speed v of two bodies with R* = r_i r_j/(r_i + r_j), m* = m_i m_j/(m_i + m_j),
1/E* = (1 - nu_i^2)/E_i + (1 - nu_j^2)/E_j (a rigid plane: R* = r, m* = m, E* = E/(1 - nu^2)):

    F(delta)  = (4/3) E* sqrt(R*) delta^(3/2)
    delta_max = (15 m* v^2 / (16 E* sqrt(R*)))^(2/5)
    F_max     = (4/3) E* sqrt(R*) delta_max^(3/2)
    t_c       = 2 (2/5) B(2/5, 1/2) delta_max / v = 2.9432 delta_max / v
              = 2.8683 (m*^2 / (R* E*^2 v))^(1/5)

(energy: 1/2 m* (v^2 - u^2) = (8/15) E* sqrt(R*) delta^(5/2), so the time in contact is
2 int_0^delta_max d delta / u = 2 (delta_max / v) int_0^1 (1 - x^(5/2))^(-1/2) dx, and the
integral is (2/5) B(2/5, 1/2) = 1.47164.)

Rigid-body oblique impact of spheres with Coulomb friction (Chung & Ooi 2011; Thornton,
Cummins & Cleary 2011, 2013; Maw, Barber & Fawcett 1976). Let v_n be the normal approach speed, v_c the
initial slip speed of the contact points (relative tangential velocity of the two surface points,
centre velocity and spin together), J_n = m* (1 + e) v_n the normal impulse. A tangential impulse
J_t against the slip changes the slip speed by -J_t (1/m_i + 1/m_j + r_i^2/I_i + r_j^2/I_j)
= -7/2 J_t / m* (I = 2/5 m r^2 for both; for a wall, m* = m). Hence, with the threshold

    v_c = 7/2 mu (1 + e) v_n:

- gross sliding (v_c >= 7/2 mu (1 + e) v_n): J_t = mu J_n, v_c' = v_c - 7/2 mu (1 + e) v_n;
  for a sphere on a wall with no initial spin: v_t' = v_t - mu (1 + e) v_n,
  omega' r = 5/2 mu (1 + e) v_n;
- sticking (below the threshold): the contact points leave together, v_c' = 0,
  J_t = 2/7 m* v_c; on a wall with no initial spin v_t' = omega' r = 5/7 v_t.

Two further bounds hold for any passive tangential contact law (they do not assume rigidity):
the friction impulse never exceeds mu times the integral of |F_n| (Coulomb), and the slip speed
cannot grow: |v_c'| <= |v_c|, because the kinetic energy that a tangential impulse can change is
1/2 (2/7 m*) v_c^2 and the contact gives nothing back beyond what it stored.

The default normal force of tsubu ("signed", the beta-form dashpot unclipped) pulls briefly at
the end of a damped impact, and the Coulomb cap is mu |F_n|. The friction impulse of a gross slip
is then mu J_abs with J_abs = int |F_n| dt > J_n: ``absolute_impulse_ratio`` integrates the
Hertz impact with the beta dashpot (RK4, no DEM step) for J_abs / J_n: 1.0671 at e = 0.5,
1.00008 at e = 0.98, exactly 1 at e = 1 and for the "repulsive" force.
"""

from __future__ import annotations

import math

import numpy as np

import tsubu

# ---- materials (E [Pa], nu, rho [kg/m^3]) as in Chung & Ooi's Table 1 ---------------------------
MATERIALS = {
    "glass": (4.8e10, 0.20, 2800.0),          # test 1
    "limestone": (2.0e10, 0.25, 2500.0),      # test 1
    "al_alloy_t2": (7.0e10, 0.30, 2699.0),    # test 2 (Al alloy as Chung & Ooi give it there)
    "mg_alloy": (4.0e10, 0.35, 1800.0),       # test 2
    "al_oxide": (3.8e11, 0.23, 4000.0),       # tests 3, 4
    "cast_iron": (1.0e11, 0.25, 7000.0),      # test 3
    "al_alloy": (7.0e10, 0.33, 2700.0),       # tests 4, 6, 7, 8
    "steel": (2.08e11, 0.30, 7850.0),         # test 5
    "polyethylene": (1.0e9, 0.40, 1400.0),    # test 5
    "nylon": (2.5e9, 0.40, 1000.0),           # tests 6, 8
    "copper": (1.2e11, 0.35, 8900.0),         # test 7
}

# ---- the cases -----------------------------------------------------------------------------------
TEST1 = dict(materials=("glass", "limestone"), radius=0.010, speed=10.0, restitution=1.0, friction=0.35)
TEST2 = dict(materials=("al_alloy_t2", "mg_alloy"), radius=0.10, speed=0.2, restitution=1.0, friction=0.0)
TEST3 = dict(materials=("al_oxide", "cast_iron"), radius=0.0025, speed=3.9,
             restitutions=(0.2, 0.4, 0.6, 0.8, 1.0), friction=0.0)
TEST4 = dict(materials=("al_oxide", "al_alloy"), radius=0.0025, speed=3.9, restitution=0.98,
             friction=0.092, angles=tuple(range(5, 90, 5)))  # degrees from the normal
TEST5 = dict(materials=("steel", "polyethylene"), radius=1e-5, normal_speed=5.0, restitution=1.0,
             friction=0.3, tangential_speeds=(0.1, 0.3, 0.45, 0.6, 0.9, 1.2, 1.5, 1.8, 2.25, 2.7, 3.0,
                                              3.75, 4.5, 5.25, 6.0, 7.5, 9.0, 12.0, 15.0, 18.0, 21.0))
SPINS = (0.175, 0.30, 0.42, 0.60, 0.80, 1.0, 1.2, 1.5, 2.0, 2.4, 2.8, 3.0, 3.5, 4.0, 6.0, 8.0, 10.0,
         12.0, 14.0, 21.0)  # rad/s, tests 6-8
TEST6 = dict(materials=("al_alloy", "nylon"), radius=0.10, normal_speed=0.2, restitution=0.5,
             friction=0.4, spins=SPINS)
TEST7 = dict(materials=("al_alloy", "copper"), radius=0.10, speed=0.2, restitution=0.5, friction=0.4,
             spins=SPINS)
TEST8 = dict(materials=("al_alloy", "nylon"), radius=0.10, radius_ratio=5.0, density_ratio=1000.0,
             speed=0.2, restitution=0.5, friction=0.4, spins=SPINS)

STEPS_PER_CONTACT = 100  # dt = t_c / 100 (Hertz's t_c at the impact speed) unless a driver is told


# ---- closed forms --------------------------------------------------------------------------------
HERTZ_DURATION_FACTOR = 2.0 * 0.4 * math.gamma(0.4) * math.gamma(0.5) / math.gamma(0.9)  # 2.94328


def sphere_mass(radius: float, density: float) -> float:
    return density * 4.0 / 3.0 * math.pi * radius ** 3


def effective_modulus(e1: float, nu1: float, e2: float = math.inf, nu2: float = 0.0) -> float:
    """1/E* = (1 - nu1^2)/E1 + (1 - nu2^2)/E2 (E2 = inf: a rigid body)."""
    return 1.0 / ((1.0 - nu1 ** 2) / e1 + (0.0 if math.isinf(e2) else (1.0 - nu2 ** 2) / e2))


def hertz_peak_overlap(m: float, r: float, estar: float, v: float) -> float:
    """delta_max = (15 m* v^2 / (16 E* sqrt(R*)))^(2/5)."""
    return (15.0 * m * v * v / (16.0 * estar * math.sqrt(r))) ** 0.4


def hertz_force(delta, r: float, estar: float):
    """F = (4/3) E* sqrt(R*) delta^(3/2)."""
    return 4.0 / 3.0 * estar * math.sqrt(r) * np.asarray(delta, float) ** 1.5


def hertz_peak_force(m: float, r: float, estar: float, v: float) -> float:
    return float(hertz_force(hertz_peak_overlap(m, r, estar, v), r, estar))


def hertz_duration(m: float, r: float, estar: float, v: float) -> float:
    """t_c = 2.9432 delta_max / v = 2.8683 (m*^2 / (R* E*^2 v))^(1/5)."""
    return HERTZ_DURATION_FACTOR * hertz_peak_overlap(m, r, estar, v) / v


def hertz_curve(m: float, r: float, estar: float, v: float, n: int = 400):
    """The elastic impact's overlap delta(t) and force F(t) over [0, t_c] (exact: t as a function
    of delta by quadrature of 1/u(delta), u = v sqrt(1 - (delta/delta_max)^(5/2)))."""
    dmax = hertz_peak_overlap(m, r, estar, v)
    x = np.linspace(0.0, 1.0, n)
    # t(x) = (dmax / v) int_0^x (1 - s^(5/2))^(-1/2) ds; substitute s = 1 - w^2 near 1 to tame the
    # square-root singularity: ds / sqrt(1 - s^2.5) = 2 w dw / sqrt(1 - (1 - w^2)^2.5).
    w = np.linspace(0.0, 1.0, 20001)[1:]
    s = 1.0 - w * w
    g = 2.0 * w / np.sqrt(1.0 - s ** 2.5)
    # cumulative integral from s = 1 (w = 0, where g -> 2/sqrt(5/2)) down to s
    g = np.concatenate([[2.0 / math.sqrt(2.5)], g])
    w = np.concatenate([[0.0], w])
    tail = np.concatenate([[0.0], np.cumsum(0.5 * (g[1:] + g[:-1]) * np.diff(w))])  # int_s^1
    total = tail[-1]  # = (2/5) B(2/5, 1/2)
    s = np.concatenate([[1.0], s])
    t_of_x = np.interp(x, s[::-1], (total - tail)[::-1]) * dmax / v
    t = np.concatenate([t_of_x, 2.0 * total * dmax / v - t_of_x[::-1]])
    delta = np.concatenate([x, x[::-1]]) * dmax
    return t, delta, hertz_force(delta, r, estar)


def beta_damping_factor(e: float) -> float:
    """eta_n / sqrt(S_n m*) of the beta form: 2 sqrt(5/6) |ln e| / sqrt(ln^2 e + pi^2)."""
    le = math.log(e)
    return 2.0 * math.sqrt(5.0 / 6.0) * abs(le) / math.sqrt(le * le + math.pi ** 2)


def absolute_impulse_ratio(e: float, steps: int = 20000) -> float:
    """J_abs / J_n = int |F_n| dt / int F_n dt of a Hertz impact with the (unclipped) beta dashpot,
    by RK4 in units m* = (4/3) E* sqrt(R*) = v = 1, where delta'' = -delta^(3/2) - c delta^(1/4)
    delta', c = beta factor x sqrt(3/2) (S_n = 2 E* sqrt(R* delta) = 3/2 delta^(1/2) there)."""
    c = beta_damping_factor(e) * math.sqrt(1.5)

    def accel(d, u):
        d = max(d, 0.0)
        return -(d ** 1.5 + c * d ** 0.25 * u)

    h = 4.0 / steps  # t_c = 3.218 in these units for e = 1, longer when damped
    d, u = 0.0, 1.0
    j_n = j_abs = 0.0
    while True:
        k1d, k1u = u, accel(d, u)
        k2d, k2u = u + 0.5 * h * k1u, accel(d + 0.5 * h * k1d, u + 0.5 * h * k1u)
        k3d, k3u = u + 0.5 * h * k2u, accel(d + 0.5 * h * k2d, u + 0.5 * h * k2u)
        k4d, k4u = u + h * k3u, accel(d + h * k3d, u + h * k3u)
        f0 = -accel(d, u)
        d_new = d + h / 6.0 * (k1d + 2 * k2d + 2 * k3d + k4d)
        u_new = u + h / 6.0 * (k1u + 2 * k2u + 2 * k3u + k4u)
        if d_new <= 0.0:
            frac = d / (d - d_new)  # the last part step, linearly
            f1 = 0.0
            j_n += 0.5 * (f0 + f1) * h * frac
            j_abs += 0.5 * (abs(f0) + abs(f1)) * h * frac
            break
        f1 = -accel(d_new, u_new)
        if f0 * f1 < 0.0:  # a sign change inside the step: split the trapezoid at the zero
            z = f0 / (f0 - f1)
            j_abs += 0.5 * (abs(f0) * z + abs(f1) * (1.0 - z)) * h
        else:
            j_abs += 0.5 * (abs(f0) + abs(f1)) * h
        j_n += 0.5 * (f0 + f1) * h
        d, u = d_new, u_new
    return j_abs / j_n


def rigid_body_impulse(slip: float, normal_speed: float, friction: float, restitution: float,
                       friction_impulse_ratio: float = 1.0) -> float:
    """J_t / m* of the rigid-body impact: mu J/m* if the contact slides throughout, else the 2/7 v_c
    that stops the slip. ``friction_impulse_ratio`` = J_abs/J_n (1: the rigid-body law)."""
    sliding = friction * friction_impulse_ratio * (1.0 + restitution) * normal_speed
    return min(sliding, slip / 3.5)


# ---- building blocks ---------------------------------------------------------------------------
def material(name: str, restitution: float, friction: float, modulus_factor: float = 1.0,
             density_factor: float = 1.0) -> tsubu.Material:
    e, nu, rho = MATERIALS[name]
    return tsubu.Material(density=rho * density_factor, youngs_modulus=e * modulus_factor,
                          poisson_ratio=nu, restitution=restitution, friction=friction, name=name)


def rigid_plane_materials(name: str, restitution: float, friction: float):
    """Sphere and wall materials for a sphere of `name` on a rigid plane: both with 2E and the same
    nu (the LIGGGHTS-PFM decks' device). Then exactly 1/E* = 2 (1 - nu^2)/(2E) = (1 - nu^2)/E and
    1/G* = 2 (2 - nu)/(2G) = (2 - nu)/G: the moduli of the sphere on an infinitely stiff plane."""
    return (material(name, restitution, friction, modulus_factor=2.0),
            material(name, restitution, friction, modulus_factor=2.0))


def rigid_plane_modulus(name: str) -> float:
    e, nu, _ = MATERIALS[name]
    return effective_modulus(e, nu)


def _simulation(dt: float, impact_speed: float, hertz_force: str = "signed", **kw) -> tsubu.Simulation:
    """No gravity, one thread, dt given. ``allow_unstable_dt``: every case runs at t_c/100 or
    finer, far below the stability bound of its stiffest contact (about t_c/3.4, see
    ``stability_bound``); the engine's own bound is checked apart, in test_chung_ooi.py
    (``test_engine_time_step_bound``), so that a wrong bound cannot stop the physics checks."""
    return tsubu.Simulation(gravity=(0.0, 0.0, 0.0), dt=dt, threads=1, impact_speed=impact_speed,
                            hertz_force=hertz_force, allow_unstable_dt=True, **kw)


def _overlap_zero_crossing(o0: float, o1: float, k0: int, dt: float) -> float:
    """Time where the overlap, linear between steps k0 (value o0) and k0 + 1 (o1), is zero."""
    return (k0 + o0 / (o0 - o1)) * dt


# ---- tests 1 and 2: elastic normal impacts, recorded step by step -------------------------------
def record_normal_impact(kind: str, name: str, radius: float, speed: float, restitution: float = 1.0,
                         friction: float = 0.0, steps_per_contact: float = STEPS_PER_CONTACT,
                         hertz_force: str = "signed") -> dict:
    """Head-on impact, no gravity, starting exactly at touch (so the contact starts on a step).

    kind "pair": two identical spheres at -+`speed` each (relative speed 2 x speed);
    kind "wall": one sphere at `speed` onto a rigid plane.

    Each step records the overlap and the normal force of the contact (``sim.contacts()``: the
    force evaluation at the start of the step, time (k - 1) dt after k steps) and the overlap from
    the positions after the step. Returns a dict: ``t``, ``overlap``, ``force`` (the contact's
    records), ``duration`` (between the linearly interpolated zero crossings of the positions'
    overlap), ``rebound`` (relative normal speed after / before), the analytic ``m``, ``r``,
    ``estar``, ``v`` and ``dt``.
    """
    e_mod, nu, rho = MATERIALS[name]
    if kind == "pair":
        m, r, v = sphere_mass(radius, rho) / 2.0, radius / 2.0, 2.0 * speed
        estar = effective_modulus(e_mod, nu, e_mod, nu)
    else:
        m, r, v = sphere_mass(radius, rho), radius, speed
        estar = rigid_plane_modulus(name)
    tc = hertz_duration(m, r, estar, v)
    dt = tc / steps_per_contact
    sim = _simulation(dt, v, hertz_force)
    if kind == "pair":
        mat = material(name, restitution, friction)
        sim.add_spheres([(-radius, 0.0, 0.0), (radius, 0.0, 0.0)], radius, mat,
                        velocities=[(speed, 0.0, 0.0), (-speed, 0.0, 0.0)])

        def gap_overlap():
            p = sim.positions
            return 2.0 * radius - (p[1, 0] - p[0, 0])

        def approach():
            u = sim.velocities
            return u[0, 0] - u[1, 0]

        def normal_force(c):  # on sphere 0, pushing it back (-x): positive when repulsive
            return -c["force"][0, 0]
    else:
        sphere, wall = rigid_plane_materials(name, restitution, friction)
        sim.add_sphere((0.0, 0.0, radius), radius, sphere, velocity=(0.0, 0.0, -speed))
        sim.add_plane(point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), material=wall)

        def gap_overlap():
            return radius - sim.positions[0, 2]

        def approach():
            return -sim.velocities[0, 2]

        def normal_force(c):
            return c["force"][0, 2]

    u0 = approach()
    t, ov, force, pos_ov = [], [], [], [gap_overlap()]
    started = False
    for k in range(1, int(4 * steps_per_contact) + 10):
        sim.run(steps=1)
        c = sim.contacts()
        if len(c["overlap"]):
            t.append((k - 1) * dt)
            ov.append(float(c["overlap"][0]))
            force.append(float(normal_force(c)))
        pos_ov.append(gap_overlap())
        started = started or pos_ov[-1] > 0.0
        if started and pos_ov[-1] <= 0.0:
            break
    else:
        raise AssertionError(f"{kind} {name}: the contact did not end within 4 t_c")
    pos_ov = np.array(pos_ov)
    i0 = int(np.argmax(pos_ov > 0.0))
    t_in = _overlap_zero_crossing(pos_ov[i0 - 1], pos_ov[i0], i0 - 1, dt) if pos_ov[i0 - 1] < 0 else (i0 - 1) * dt
    i1 = len(pos_ov) - 1
    t_out = _overlap_zero_crossing(pos_ov[i1 - 1], pos_ov[i1], i1 - 1, dt)
    return dict(t=np.array(t), overlap=np.array(ov), force=np.array(force), duration=t_out - t_in,
                rebound=-approach() / u0, m=m, r=r, estar=estar, v=v, dt=dt, tc=tc, sim=sim)


def hertz_errors(rec: dict) -> dict:
    """Relative errors of the recorded impact against Hertz: peak force, peak overlap, duration,
    and the largest relative deviation of a recorded (overlap, force) pair from F(delta)."""
    m, r, estar, v = rec["m"], rec["r"], rec["estar"], rec["v"]
    f_curve = hertz_force(rec["overlap"], r, estar)
    on = rec["overlap"] > 0
    return dict(
        peak_force=rec["force"].max() / hertz_peak_force(m, r, estar, v) - 1.0,
        peak_overlap=rec["overlap"].max() / hertz_peak_overlap(m, r, estar, v) - 1.0,
        duration=rec["duration"] / hertz_duration(m, r, estar, v) - 1.0,
        curve=float(np.max(np.abs(rec["force"][on] / f_curve[on] - 1.0))),
        rebound=rec["rebound"] - 1.0,
    )


# ---- test 3 and the oblique wall impacts (tests 4-6) ---------------------------------------------
def wall_impact(name: str, radius: float, normal_speed: float, tangential_speed: float = 0.0,
                spin: float = 0.0, restitution: float = 1.0, friction: float = 0.0,
                hertz_force: str = "signed", steps_per_contact: float = STEPS_PER_CONTACT,
                slip_rule: str = "frozen") -> dict:
    """A sphere of `name` touching the rigid plane z = 0 with velocity (v_t, 0, -v_n) and angular
    velocity (0, -spin, 0) (a spin whose surface slides along +x at the contact: the contact
    point's velocity is v_t + r spin along +x). Runs until the contact has ended.

    Returns the normal speed after ``vn1`` (> 0 leaving), the centre's tangential speed ``vt1``, the
    spin ``wy1`` (about +y: > 0 is topspin, rolling along +x), the contact point's slip velocity
    along x before ``vc0`` = v_t + r spin and after ``vc1`` = v_t' - r w_y', and the inputs.
    """
    e_mod, nu, rho = MATERIALS[name]
    m = sphere_mass(radius, rho)
    estar = rigid_plane_modulus(name)
    tc = hertz_duration(m, radius, estar, normal_speed)
    dt = tc / steps_per_contact
    sim = _simulation(dt, normal_speed, hertz_force, slip_rule=slip_rule)
    sphere, wall = rigid_plane_materials(name, restitution, friction)
    sim.add_sphere((0.0, 0.0, radius), radius, sphere, velocity=(tangential_speed, 0.0, -normal_speed),
                   angular_velocity=(0.0, -spin, 0.0))
    sim.add_plane(point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), material=wall)
    chunk = max(1, int(steps_per_contact) // 10)
    touched = False
    for _ in range(int(4 * steps_per_contact) // chunk + 2):
        sim.run(steps=chunk)
        in_contact = sim.positions[0, 2] < radius or len(sim.contacts()["i"]) > 0
        touched = touched or in_contact
        if touched and not in_contact:
            break
    else:
        raise AssertionError(f"wall impact {name}: the contact did not end within 4 t_c")
    v, w = sim.velocities[0], sim.angular_velocities[0]
    assert abs(v[1]) < 1e-12 * (abs(normal_speed) + abs(tangential_speed)) and abs(w[0]) < 1e-9 * (1 + abs(w[1]))
    return dict(vn0=normal_speed, vt0=tangential_speed, spin0=spin, vc0=tangential_speed + radius * spin,
                vn1=float(v[2]), vt1=float(v[0]), wy1=float(w[1]), vc1=float(v[0] - radius * w[1]),
                radius=radius, mass=m, restitution=restitution, friction=friction, dt=dt, tc=tc,
                delta_max=hertz_peak_overlap(m, radius, estar, normal_speed),
                # J_t / m* and the spin change x I / (r m*): equal when the lever is r
                impulse=tangential_speed - float(v[0]), spin_impulse=0.4 * radius * (float(w[1]) + spin))


def friction_impulse_ratio(res: dict) -> float:
    """J_t / (mu J_n), both measured: the tangential impulse from the change of the centre's
    velocity (no lever arm involved), the normal one m* (v_n + v_n'). 1 for the rigid-body law in
    gross slip; J_abs/J_n there with the signed force; below it while the contact sticks."""
    return res["impulse"] / (res["friction"] * (res["vn0"] + res["vn1"]))


def normalised_slip(res: dict) -> float:
    """psi = v_c / (7/2 mu (1 + e) v_n): the initial slip in units of the rigid-body threshold
    (psi > 1: the contact slides throughout; psi < 1: it sticks)."""
    return abs(res["vc0"]) / (3.5 * res["friction"] * (1.0 + res["restitution"]) * res["vn0"])


# ---- tests 7 and 8: two spheres ----------------------------------------------------------------
def pair_impact(name: str, radius: float, speed: float, spin1: float, spin2: float,
                restitution: float, friction: float, radius2: float | None = None, density_factor2: float = 1.0,
                modulus_factor2: float = 1.0, name2: str | None = None, speed2: float | None = None,
                hertz_force: str = "signed", steps_per_contact: float = STEPS_PER_CONTACT) -> dict:
    """Sphere 1 (radius `radius`) above sphere 2 (radius `radius2`, default equal), touching, on the
    z axis; sphere 1 moves at -`speed` along z, sphere 2 at +`speed2` (default: `speed`). Spins
    about x: sphere 1 `spin1`, sphere 2 `spin2`. The contact point of sphere 1 (at -r1 z from its
    centre) moves at +r1 spin1 along y, that of sphere 2 (at +r2 z) at -r2 spin2 along y: the slip
    speed before is v_c = r1 spin1 + r2 spin2 along +y (zero for spin2 = -spin1).

    Returns the velocities and spins after (``v1``, ``w1``, ``v2``, ``w2``), the normal approach
    speed before and separation speed after (``vn0``, ``vn1``), the slip before and after along y
    (``vc0``, ``vc1``) and the inputs.
    """
    r1 = radius
    r2 = radius if radius2 is None else radius2
    speed2 = speed if speed2 is None else speed2
    e_mod, nu, rho = MATERIALS[name]
    e2, nu2, rho2 = MATERIALS[name2 or name]
    m1, m2 = sphere_mass(r1, rho), sphere_mass(r2, rho2 * density_factor2)
    m_star, r_star = m1 * m2 / (m1 + m2), r1 * r2 / (r1 + r2)
    estar = effective_modulus(e_mod, nu, e2 * modulus_factor2, nu2)
    vn0 = speed + speed2
    tc = hertz_duration(m_star, r_star, estar, vn0)
    dt = tc / steps_per_contact
    sim = _simulation(dt, vn0, hertz_force)
    mat1 = material(name, restitution, friction)
    mat2 = material(name2 or name, restitution, friction, modulus_factor=modulus_factor2,
                    density_factor=density_factor2)
    sim.add_sphere((0.0, 0.0, r1), r1, mat1, velocity=(0.0, 0.0, -speed), angular_velocity=(spin1, 0.0, 0.0))
    sim.add_sphere((0.0, 0.0, -r2), r2, mat2, velocity=(0.0, 0.0, speed2), angular_velocity=(spin2, 0.0, 0.0))
    chunk = max(1, int(steps_per_contact) // 10)
    touched = False
    for _ in range(int(4 * steps_per_contact) // chunk + 2):
        sim.run(steps=chunk)
        p = sim.positions
        in_contact = p[0, 2] - p[1, 2] < r1 + r2 or len(sim.contacts()["i"]) > 0
        touched = touched or in_contact
        if touched and not in_contact:
            break
    else:
        raise AssertionError(f"pair impact {name}: the contact did not end within 4 t_c")
    v, w = sim.velocities, sim.angular_velocities
    vc1 = (v[0, 1] + r1 * w[0, 0]) - (v[1, 1] - r2 * w[1, 0])
    return dict(v1=v[0].copy(), w1=w[0].copy(), v2=v[1].copy(), w2=w[1].copy(), vn0=vn0,
                vn1=float(v[0, 2] - v[1, 2]), vc0=r1 * spin1 + r2 * spin2, vc1=float(vc1),
                spin1=spin1, spin2=spin2, r1=r1, r2=r2, m1=m1, m2=m2, m_star=m_star,
                restitution=restitution, friction=friction, dt=dt, tc=tc,
                delta_max=hertz_peak_overlap(m_star, r_star, estar, vn0),
                # J_t / m* against the initial slip (the impulse on sphere 1 is -J_t along the slip)
                impulse=-math.copysign(1.0, r1 * spin1 + r2 * spin2) * m1 * float(v[0, 1]) / m_star)


# ---- the no-slip limit of Mindlin's spring (mu -> infinity) --------------------------------------
def no_slip_exit_slip(name: str, radius: float, normal_speed: float, steps: int = 4000) -> float:
    """v_c' / v_c of an elastic (e = 1) oblique impact of a sphere of `name` on a rigid plane when the
    contact never slides (mu -> infinity), with no initial spin, integrated by RK4 (no DEM step).

    The tangential spring is Mindlin's k_t = 8 G* a, a = sqrt(R delta), G* = G/(2 - nu) for the rigid
    plane, held as docs/physics.md describes it: while the contact loads (a grows) the force follows
    the incremental law dF_t = k_t v_c dt (the stored displacement is rescaled so that F_t = k_t xi does
    not jump); while it unloads xi is kept and F_t = k_t xi falls with a (Mindlin & Deresiewicz 1953,
    as Thornton, Cummins & Cleary 2013 recommend). The force acts at the contact point, c = R - delta/2
    below the centre; the normal motion is Hertz's (it does not feel the tangential force on a plane).
    The ratio depends only on nu (and weakly, through c, on delta_max/R): the slip speed is linear in
    v_t and the impact is self-similar in v_n.
    """
    e_mod, nu, rho = MATERIALS[name]
    estar = rigid_plane_modulus(name)
    gstar = e_mod / (2.0 * (1.0 + nu)) / (2.0 - nu)
    m = sphere_mass(radius, rho)
    inertia = 0.4 * m * radius * radius
    kn = 4.0 / 3.0 * estar * math.sqrt(radius)
    h = hertz_duration(m, radius, estar, normal_speed) / steps
    vt0 = 1.0  # any: the problem is linear in v_t

    def rates(y, loading):
        d, dd, q, vx, wy = y  # q: F_t while loading, xi while unloading
        dp = max(d, 0.0)
        kt = 8.0 * gstar * math.sqrt(radius * dp)
        ft = q if loading else kt * q  # magnitude of the spring force, acting along -x on the sphere
        c = radius - 0.5 * dp
        vc = vx - c * wy
        return (dd, -kn * dp ** 1.5 / m, kt * vc if loading else vc, -ft / m, c * ft / inertia)

    def rk4(y, loading):
        k1 = rates(y, loading)
        k2 = rates([a + 0.5 * h * b for a, b in zip(y, k1)], loading)
        k3 = rates([a + 0.5 * h * b for a, b in zip(y, k2)], loading)
        k4 = rates([a + h * b for a, b in zip(y, k3)], loading)
        return [a + h / 6.0 * (b + 2 * c + 2 * d + e) for a, b, c, d, e in zip(y, k1, k2, k3, k4)]

    y = [0.0, normal_speed, 0.0, vt0, 0.0]
    loading = True
    for _ in range(10 * steps):
        y_new = rk4(y, loading)
        if loading and y_new[1] <= 0.0:
            # the peak: take the step to where the overlap rate vanishes (linearly), switch to xi
            f = y[1] / (y[1] - y_new[1])
            y = [a + f * (b - a) for a, b in zip(y, y_new)]
            y[2] = y[2] / (8.0 * gstar * math.sqrt(radius * y[0]))
            loading = False
            continue
        if not loading and y_new[0] <= 0.0:
            f = y[0] / (y[0] - y_new[0])
            y = [a + f * (b - a) for a, b in zip(y, y_new)]
            return (y[3] - radius * y[4]) / vt0
        y = y_new
    raise AssertionError("the no-slip impact did not end")


def rigid_plane_shear_modulus(name: str) -> float:
    """G* of a sphere on a rigid plane: 1/G* = (2 - nu)/G, G = E / (2 (1 + nu))."""
    e_mod, nu, _ = MATERIALS[name]
    return e_mod / (2.0 * (1.0 + nu)) / (2.0 - nu)


def stability_bound(m: float, r: float, estar: float, gstar: float, v: float, restitution: float,
                    friction: bool = True) -> float:
    """The symplectic-Euler bound of one Hertz-Mindlin contact at the stiffest point of an impact at
    v, as docs/physics.md states it: the normal spring S_n = 2 E* a with its beta dashpot,
    dt < 4 m* / (eta + sqrt(eta^2 + 4 S_n m*)), and Mindlin's k_t = 8 G* a on the mass m*/3.5 that
    a rolling sphere's contact point has, dt < 2 sqrt(m* / (3.5 k_t)); a = sqrt(R* delta_max).
    Close to t_c/2.0 (normal, e = 1) and t_c/3.4 (tangential, nu = 0.3)."""
    a = math.sqrt(r * hertz_peak_overlap(m, r, estar, v))
    sn = 2.0 * estar * a
    eta = beta_damping_factor(restitution) * math.sqrt(sn * m)
    bound = 4.0 * m / (eta + math.sqrt(eta * eta + 4.0 * sn * m))
    if friction:
        bound = min(bound, 2.0 * math.sqrt(m / (3.5 * 8.0 * gstar * a)))
    return bound
