"""Two steel spheres colliding obliquely (Hertz-Mindlin): the force on sphere 0 at every step.

Sphere 1 rests; sphere 0 hits it at 1 m/s, at an angle theta from the line of centres (10, 30
and 75 degrees). The normal force is compared with Hertz's closed form for the elastic impact
(restitution 1, so the closed form is exact for the contact law), the tangential force with
Coulomb's limit mu F_n:

- at 75 degrees the contact slides throughout (the rigid-body threshold is
  tan(theta) > 7/2 mu (1 + e), 64.5 degrees here): F_t = mu F_n at every step;
- at 30 degrees it slides at first (Mindlin's k_t/k_n would carry more than mu F_n), then
  sticks and slides again as the normal force falls;
- at 10 degrees it sticks most of the time and the tangential force reverses at the end
  (the stored tangential spring gives its energy back), as Maw, Barber & Fawcett (1976) found.

Run:  python examples/oblique_collision.py [--quick] [--out DIR] [--figure PNG | --no-figure]

Both slip rules of tsubu are run: "truncate" (LAMMPS, LIGGGHTS) and "frozen" (the default).
Writes DIR/oblique_collision_<rule>.csv (one row per step in contact: angle, time, overlap,
normal and tangential force), DIR/oblique_collision.json (the summary printed at the end), then
the figure (matplotlib, headless). docs/examples.md shows the figure and the timings.
"""

from __future__ import annotations

import math
import os
import sys
import time

import numpy as np

import tsubu

from example_support import arguments, figure_path, pyplot, save_figure, write_json  # beside this script

# Steel, as in Chung & Ooi (2011), test 5: E = 208 GPa, nu = 0.3, 7850 kg/m^3.
YOUNGS_MODULUS = 2.08e11  # Pa
POISSON_RATIO = 0.3
DENSITY = 7850.0  # kg/m^3
RADIUS = 0.01  # m
SPEED = 1.0  # m/s, sphere 0's speed; sphere 1 is at rest
FRICTION = 0.3
ANGLES = (10.0, 30.0, 75.0)  # degrees between sphere 0's velocity and the line of centres
# "truncate" (LAMMPS, LIGGGHTS) first: the figure's main curves; "frozen" (tsubu's default).
SLIP_RULES = ("truncate", "frozen")


def hertz_constants():
    """m*, R*, E* of the pair and Hertz's peak overlap, peak force and duration at the normal
    approach speed v_n = SPEED (Johnson 1985, Contact Mechanics, sections 4.2 and 11.4)."""
    mass = DENSITY * 4.0 / 3.0 * math.pi * RADIUS ** 3
    m_star, r_star = mass / 2.0, RADIUS / 2.0
    e_star = YOUNGS_MODULUS / (2.0 * (1.0 - POISSON_RATIO ** 2))  # 1/E* = 2 (1 - nu^2)/E
    return m_star, r_star, e_star


def hertz_impact(normal_speed: float, samples: int = 4000):
    """The elastic Hertz impact F(t) = (4/3) E* sqrt(R*) delta^(3/2), m* delta'' = -F,
    delta(0) = 0, delta'(0) = v_n, integrated with RK4 on a fine grid (far finer than the DEM
    step, so its error is negligible). Returns (t, F) over the contact and t_c."""
    m_star, r_star, e_star = hertz_constants()
    stiffness = 4.0 / 3.0 * e_star * math.sqrt(r_star)
    delta_max = (15.0 * m_star * normal_speed ** 2 / (16.0 * e_star * math.sqrt(r_star))) ** 0.4
    t_c = 2.9432 * delta_max / normal_speed  # 2 (2/5) B(2/5, 1/2) delta_max / v, for the step
    h = 1.05 * t_c / samples

    def accel(d):
        return -stiffness * max(d, 0.0) ** 1.5 / m_star

    d, u, t = 0.0, normal_speed, [0.0]
    force = [0.0]
    while True:
        k1d, k1u = u, accel(d)
        k2d, k2u = u + 0.5 * h * k1u, accel(d + 0.5 * h * k1d)
        k3d, k3u = u + 0.5 * h * k2u, accel(d + 0.5 * h * k2d)
        k4d, k4u = u + h * k3u, accel(d + h * k3d)
        d_next = d + h / 6.0 * (k1d + 2 * k2d + 2 * k3d + k4d)
        u = u + h / 6.0 * (k1u + 2 * k2u + 2 * k3u + k4u)
        if d_next <= 0.0:  # separation, between this point and the next: linearly
            t_end = t[-1] + h * d / (d - d_next)
            t.append(t_end)
            force.append(0.0)
            return np.array(t), np.array(force), t_end
        d = d_next
        t.append(t[-1] + h)
        force.append(stiffness * d ** 1.5)


def collide(angle_deg: float, steps_per_contact: int, slip_rule: str = "truncate") -> dict:
    """One impact at `angle_deg`, dt = t_c / steps_per_contact, recorded step by step.

    Returns t [s] (the time of each force evaluation), overlap [m], normal force F_n [N] (> 0
    pushing sphere 0 away from sphere 1) and tangential force F_t [N] (its component against
    sphere 0's initial tangential motion: > 0 while it brakes the slip), and the velocities
    after the contact."""
    theta = math.radians(angle_deg)
    normal_speed = SPEED * math.cos(theta)
    m_star, r_star, e_star = hertz_constants()
    delta_max = (15.0 * m_star * normal_speed ** 2 / (16.0 * e_star * math.sqrt(r_star))) ** 0.4
    t_c = 2.9432 * delta_max / normal_speed
    dt = t_c / steps_per_contact
    steel = tsubu.Material(density=DENSITY, youngs_modulus=YOUNGS_MODULUS,
                           poisson_ratio=POISSON_RATIO, restitution=1.0, friction=FRICTION)
    sim = tsubu.Simulation(gravity=(0.0, 0.0, 0.0), dt=dt, threads=1, impact_speed=normal_speed,
                           slip_rule=slip_rule)
    # Touching at t = 0, so that the contact starts on a step and the curves share their origin.
    sim.add_spheres([(0.0, 0.0, 0.0), (2.0 * RADIUS, 0.0, 0.0)], RADIUS, steel,
                    velocities=[(normal_speed, SPEED * math.sin(theta), 0.0), (0.0, 0.0, 0.0)])
    t, overlap, f_n, f_t = [], [], [], []
    for _ in range(3 * steps_per_contact):
        before = sim.positions  # the positions the next step's force evaluation sees
        sim.run(steps=1)
        c = sim.contacts()
        row = np.flatnonzero((c["i"] == 0) & (c["j"] == 1))
        if len(row) == 0:
            if t:
                break  # the contact has ended
            continue
        force = c["force"][row[0]]
        normal = before[0] - before[1]
        normal /= np.linalg.norm(normal)
        fn = float(force @ normal)
        tangential = force - fn * normal
        t.append(sim.time - dt)
        overlap.append(float(c["overlap"][row[0]]))
        f_n.append(fn)
        # Sphere 0 moves along +y: friction against that slip pushes it along -y.
        f_t.append(math.copysign(float(np.linalg.norm(tangential)), -tangential[1]))
    else:
        raise RuntimeError(f"the contact at {angle_deg} degrees did not end within 3 t_c")
    return dict(angle=angle_deg, slip_rule=slip_rule, dt=dt, t_c=t_c, normal_speed=normal_speed, t=np.array(t),
                overlap=np.array(overlap), normal_force=np.array(f_n),
                tangential_force=np.array(f_t), velocities=sim.velocities,
                angular_velocities=sim.angular_velocities)


def summarise(records: list) -> dict:
    """The figures the example reports, per angle: the peak normal force and contact duration
    against Hertz, the largest |F_t| / (mu F_n), and the fraction of the contact spent sliding."""
    summary = {}
    for rec in records:
        t_ref, f_ref, t_c = hertz_impact(rec["normal_speed"])
        f_n, f_t = rec["normal_force"], rec["tangential_force"]
        loaded = f_n > 1e-3 * f_n.max()
        ratio = np.abs(f_t[loaded]) / (FRICTION * f_n[loaded])
        duration = (len(rec["t"]) + 1) * rec["dt"]  # steps with a force, and the touch at t = 0
        summary[f"{rec['slip_rule']} {rec['angle']:g}"] = dict(
            dt=rec["dt"],
            peak_normal_force=float(f_n.max()),
            hertz_peak_normal_force=float(f_ref.max()),
            peak_force_error=float(f_n.max() / f_ref.max() - 1.0),
            duration=duration,
            hertz_duration=t_c,
            duration_error=duration / t_c - 1.0,
            max_friction_ratio=float(ratio.max()),
            sliding_fraction=float(np.mean(ratio > 1.0 - 1e-3)),
            force_reverses=bool(f_t.min() < -1e-6 * f_t.max()),
        )
    return summary


def write_outputs(records: list, summary: dict, out: str) -> None:
    """One CSV per slip rule (a row per step in contact) and the summary as JSON."""
    os.makedirs(out, exist_ok=True)
    for rule in SLIP_RULES:
        rows = [(rec["angle"], t, d, fn, ft) for rec in records if rec["slip_rule"] == rule
                for t, d, fn, ft in zip(rec["t"], rec["overlap"], rec["normal_force"],
                                        rec["tangential_force"])]
        np.savetxt(os.path.join(out, f"oblique_collision_{rule}.csv"), np.array(rows),
                   delimiter=",", comments="",
                   header="angle_deg,time_s,overlap_m,normal_force_N,tangential_force_N")
    write_json(os.path.join(out, "oblique_collision.json"), summary)


def plot(out: str, figure: str) -> None:
    """The figure, from the files in `out` only (so it can be redrawn without rerunning)."""
    plt = pyplot()

    fig, axes = plt.subplots(1, 3, figsize=(15, 4.4))
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    ax_n = axes[0]
    for ax, rule in zip(axes[1:], SLIP_RULES):
        data = np.loadtxt(os.path.join(out, f"oblique_collision_{rule}.csv"), delimiter=",",
                          skiprows=1, ndmin=2)
        for colour, angle in zip(colours, np.unique(data[:, 0])):
            rows = data[data[:, 0] == angle]
            t_us = rows[:, 1] * 1e6
            if rule == SLIP_RULES[0]:
                normal_speed = SPEED * math.cos(math.radians(angle))
                t_ref, f_ref, _ = hertz_impact(normal_speed)
                ax_n.plot(t_ref * 1e6, f_ref, "-", color=colour, lw=3, alpha=0.35)
                ax_n.plot(t_us, rows[:, 3], ".", color=colour, ms=3,
                          label=f"{angle:g}°, v_n = {normal_speed:.2f} m/s")
            ax.fill_between(t_us, -FRICTION * rows[:, 3], FRICTION * rows[:, 3], color=colour,
                            alpha=0.08, lw=0)
            ax.plot(t_us, FRICTION * rows[:, 3], "--", color=colour, lw=0.8)
            ax.plot(t_us, -FRICTION * rows[:, 3], "--", color=colour, lw=0.8)
            ax.plot(t_us, rows[:, 4], ".-", color=colour, ms=3, lw=0.8, label=f"{angle:g}°")
        ax.plot([], [], "--", color="grey", lw=0.8, label="Coulomb limits ± μ F_n")
        ax.axhline(0.0, color="k", lw=0.5)
        ax.set(xlabel="time [µs]", ylabel="tangential force against the initial slip [N]",
               title=f'Tangential force, slip_rule="{rule}"')
        ax.legend(fontsize=8)
    ax_n.plot([], [], "-", color="grey", lw=3, alpha=0.35, label="Hertz, closed form")
    ax_n.set(xlabel="time [µs]", ylabel="normal force on sphere 0 [N]",
             title="Normal force: tsubu (dots) and Hertz")
    ax_n.legend(fontsize=8)
    fig.suptitle(f"Oblique impact of two steel spheres (Hertz-Mindlin), r = {RADIUS * 1e3:g} mm, "
                 f"|v| = {SPEED:g} m/s, e = 1, μ = {FRICTION:g}", fontsize=11)
    fig.tight_layout()
    save_figure(fig, figure)


def main(argv=None) -> dict:
    parser = arguments(__doc__.split("\n")[0], "oblique_collision")
    parser.add_argument("--quick", action="store_true",
                        help="coarser steps (t_c/50 instead of t_c/200): a test, in well under a second")
    args = parser.parse_args(argv)
    started = time.perf_counter()
    steps = 50 if args.quick else 200
    records = [collide(angle, steps, rule) for rule in SLIP_RULES for angle in ANGLES]
    summary = summarise(records)
    write_outputs(records, summary, args.out)
    figure = figure_path(args, "oblique_collision")
    if figure:
        plot(args.out, figure)
    for key, s in summary.items():
        print(f"{key:>12} deg: peak F_n {s['peak_normal_force']:6.1f} N (Hertz "
              f"{s['hertz_peak_normal_force']:6.1f} N, {100 * s['peak_force_error']:+.2f} %), "
              f"contact {s['duration'] * 1e6:5.2f} us (Hertz {s['hertz_duration'] * 1e6:5.2f} us), "
              f"max |F_t|/(mu F_n) {s['max_friction_ratio']:.6f}, sliding "
              f"{100 * s['sliding_fraction']:3.0f} % of the contact"
              f"{', F_t reverses' if s['force_reverses'] else ''}")
    print(f"wrote {args.out} in {time.perf_counter() - started:.1f} s")
    return summary


if __name__ == "__main__":
    main(sys.argv[1:])
