"""The mu(I) rheology: simple shear of frictional spheres at constant pressure in a periodic cube.

About 2,000 spheres (diameter d = 2 mm, density 2500 kg/m^3, linear spring-dashpot kn = 1e4 N/m,
kt = 2/7 kn, restitution 0.5, Coulomb friction 0.5: the law of ``benchmarks/shear_lammps.py``) fill
a cube periodic along x, y and z. Lees-Edwards images shear it (``sim.set_shear``: flow along x,
gradient along z) at a rate chosen for a target inertial number I = rate d / sqrt(p / rho), and
the box's z length then follows the target normal stress p = 5 kPa (``sim.set_pressure`` on z), so that
kn / (p d) = 1e3: the rigid limit of the grains (overlaps ~ 1e-3 d). For each of six inertial
numbers from 1e-3 to 0.3 (log-spaced) the cell is

- built: a random packing compressed to solid fraction 0.6 by frictionless damped relaxations
  (``shear_lammps.make_packing``), then expanded to a guess of the steady solid fraction at that
  I (``phi_guess``, from trial runs), velocities on the shear profile;
- sheared at constant volume through a strain of 0.15 (until then p ~ 0: the shear builds the
  contact network), then under pressure control to a strain of 0.5 (the transient);
- sheared through a measured strain of 2 (1.5 at I = 3e-3, 1 at I = 1e-3), ``sim.stress()`` sampled every 0.01 of strain:
  the shear stress tau = sigma_xz (positive for a positive rate: tension-positive Cauchy stress),
  the normal stress on the gradient face p = -sigma_zz (the pressure the control holds, and the
  one the literature divides by), the mean pressure -trace(sigma)/3 as well, and the solid
  fraction phi = N V_sphere / V_box.

mu = <tau> / <p> and I = rate d / sqrt(<p> / rho) use the measured mean p (within 5 % of the
target in the full run: docs/rheology.md). The error bars are the standard deviation of mu (and
phi) over ``BLOCKS`` equal blocks of the measurement. The points are fitted by Jop, Forterre & Pouliquen's (2006) law,

    mu(I) = mu_s + (mu_2 - mu_s) / (I_0 / I + 1),

weighted least squares (linear in mu_s and mu_2 for a given I_0; I_0 by a search on a log grid),
and phi(I) by a straight line phi_c - a I. The gain of the pressure control is proportional to
the shear rate (``gain``): an error is corrected over a fixed shear strain (0.01 for an elastic
response of stiffness kn / d; the flowing pack is far softer and takes ~0.2), not a fixed time; a fixed gain would either take tens of strain units to correct a
guess of phi by a per cent at I = 0.3 or chase the pressure's fluctuations at I = 1e-3.

The steps per unit strain grow as sqrt(kn / (p d)) / I (about 960,000 at I = 1e-3): the slow
end costs most of the run (docs/rheology.md gives its time on 2 cores).

Run:  python examples/mu_of_i.py [--quick] [--threads 2] [--out DIR] [--figure PNG | --no-figure]

Writes DIR/mu_of_i.json (the points and the fit), DIR/mu_of_i_<k>.npz (the samples of point k)
and the figure (matplotlib, headless): mu against I with the fit and the published law, phi
against I.
"""

from __future__ import annotations

import functools
import math
import os
import sys
import time

import numpy as np

from example_support import arguments, figure_path, pyplot, save_figure, write_json  # beside this script

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "benchmarks"))
import shear_lammps as shear  # noqa: E402  (the packing, the law, the simulation's options)

D, R, RHO, KN = shear.D, shear.R, shear.RHO, shear.KN
KAPPA = 1.0e3                      # kn / (p d): the stiffness number
PRESSURE = KN / (KAPPA * D)        # target normal stress on the gradient face [Pa]: 5 kPa
FRICTION, RESTITUTION = shear.MU, shear.E_REST
INERTIAL = np.logspace(-3.0, math.log10(0.3), 6)
SAMPLE = 0.01                      # strain between stress samples
BLOCKS = 5                         # blocks of the measurement for the error bars
SPHERES = 2000

# Jop, Forterre & Pouliquen, Nature 441 (2006) 727: glass beads (d = 0.53 mm) flowing down a
# rough incline, mu_s = tan 20.9 deg, mu_2 = tan 32.76 deg, I_0 = 0.279.
JOP = {"mu_s": math.tan(math.radians(20.9)), "mu_2": math.tan(math.radians(32.76)), "I_0": 0.279}


def plan(inertial: float, quick: bool = False) -> dict:
    """Spheres and strains for one point: the strain sheared at constant volume, the strain at
    which the measurement starts (the transient's end) and the measured strain. The pressure
    control starts after ``constant_volume``: until the shear has built a contact network p is
    ~0, and the control would compress the box past the steady solid fraction. The slow end is
    measured over less strain (its steps per unit strain grow as 1 / I)."""
    if quick:
        return {"spheres": 500, "constant_volume": 0.1, "settle": 0.2, "measure": 0.3}
    measure = 1.0 if inertial < 2e-3 else 1.5 if inertial < 6e-3 else 2.0
    return {"spheres": SPHERES, "constant_volume": 0.15, "settle": 0.5, "measure": measure}


def phi_guess(inertial: float) -> float:
    """A first guess of the steady solid fraction at ``inertial`` (from trial runs of this
    cell); the pressure control corrects it."""
    return 0.59 - 0.15 * inertial


RELAX_STRAIN = 0.01                # strain over which the pressure control corrects an error


def gain(rate: float) -> float:
    """The pressure control's gain [1/(Pa s)]: a pack of stiffness K = kn / d (set_pressure's
    estimate) brought back to the target over a shear strain RELAX_STRAIN, gain = rate / (K
    RELAX_STRAIN)."""
    return rate / (KN / D * RELAX_STRAIN)


def shear_rate(inertial: float, pressure: float = PRESSURE) -> float:
    """The rate [1/s] giving the inertial number ``inertial`` at the normal stress ``pressure``."""
    return inertial * math.sqrt(pressure / RHO) / D


I0_RANGE = (1e-3, 1.0)             # the fit's bounds on I_0 (published values: ~0.3)


def fit_mu(inertial, mu, error=None, i0_range=I0_RANGE):
    """Jop et al.'s law fitted to (I, mu): (mu_s, mu_2, I_0). Weighted least squares, linear in
    mu_s and mu_2 for a given I_0, I_0 searched on a log grid within ``i0_range`` and refined.
    (Points that do not reach the law's plateau leave mu_2 and I_0 degenerate, the law then
    being mu_s + (mu_2 - mu_s) I / I_0: the bound keeps I_0 in the published range, and the
    initial slope (mu_2 - mu_s) / I_0 is what such points determine.)"""
    i, m = np.asarray(inertial, float), np.asarray(mu, float)
    w = np.ones_like(m) if error is None else 1.0 / np.maximum(np.asarray(error, float), 1e-3)

    def solve(i0):
        s = 1.0 / (i0 / i + 1.0)
        a = np.stack([1.0 - s, s], axis=1) * w[:, None]
        coef, *_ = np.linalg.lstsq(a, m * w, rcond=None)
        return float(np.sum((a @ coef - m * w) ** 2)), coef

    lo, hi = i0_range
    grid = np.logspace(math.log10(lo), math.log10(hi), 301)
    best = min(grid, key=lambda g: solve(g)[0])
    for step in (1.02, 1.001):  # refine around the best
        grid = np.clip(best * step ** np.arange(-25, 26), lo, hi)
        best = min(grid, key=lambda g: solve(g)[0])
    coef = solve(best)[1]
    return float(coef[0]), float(coef[1]), float(best)


def mu_law(inertial, mu_s, mu_2, i_0):
    i = np.asarray(inertial, float)
    return mu_s + (mu_2 - mu_s) / (i_0 / i + 1.0)


@functools.lru_cache(maxsize=2)
def packing(spheres: int, threads, seed: int = 1) -> dict:
    """``spheres`` in a periodic cube at solid fraction 0.6 (benchmarks/shear_lammps.py's:
    random sequential addition, then scaled in steps with frictionless damped relaxations)."""
    return shear.make_packing(spheres, 0.6, threads=threads, seed=seed, log=lambda *a: None)


def cell(spheres: int, phi: float, rate: float, threads, seed: int = 1):
    """The sheared cube of ``spheres`` at solid fraction ``phi`` (no pressure control yet)."""
    state = packing(spheres, threads, seed)
    scale = (0.6 / phi) ** (1.0 / 3.0)
    x, length = state["x"] * scale, state["L"] * scale
    sim = shear.new_simulation(threads, initial_overlap=1.0)
    sim.add_spheres(x, R, shear.material(restitution=RESTITUTION, friction=FRICTION),
                    velocities=shear.shear_profile(x, length, rate))
    sim.set_box((0.0, 0.0, 0.0), (length, length, length), periodic="xyz")
    sim.set_shear(rate, flow="x", gradient="z")
    return sim


def measure_point(inertial: float, quick: bool, threads) -> dict:
    """Shear one cell at the inertial number ``inertial``; its samples and averages."""
    p = plan(inertial, quick)
    rate = shear_rate(inertial)
    sim = cell(p["spheres"], phi_guess(inertial), rate, threads)
    steps = max(1, round(SAMPLE / (rate * sim.dt)))  # steps per sample
    v_sphere = 4.0 / 3.0 * math.pi * R ** 3
    t0 = time.perf_counter()
    rows = []
    total = round((p["settle"] + p["measure"]) / SAMPLE)
    control = round(p["constant_volume"] / SAMPLE)
    for k in range(total):
        if k == control:
            sim.set_pressure(PRESSURE, gain(rate), axis="z")
        sim.run(steps=steps)
        s = sim.stress()
        lo, hi = sim.box.lower, sim.box.upper
        phi = p["spheres"] * v_sphere / float(np.prod(hi - lo))
        rows.append([(k + 1) * steps * sim.dt * rate, s[0, 2], s[2, 0], -s[2, 2], -np.trace(s) / 3.0, phi])
    seconds = time.perf_counter() - t0
    a = np.array(rows)
    strain, tau, tau_zx, pzz, pmean, phi = a.T
    used = strain > p["settle"] + 1e-9
    blocks = np.array_split(np.flatnonzero(used), BLOCKS)
    mu_b = np.array([tau[b].mean() / pzz[b].mean() for b in blocks])
    phi_b = np.array([phi[b].mean() for b in blocks])
    p_mean = float(pzz[used].mean())
    return {
        "target_inertial": float(inertial), "spheres": p["spheres"], "rate": rate, "dt": sim.dt,
        "constant_volume_strain": p["constant_volume"], "settle_strain": p["settle"], "measured_strain": p["measure"], "steps": int(total * steps),
        "gain": gain(rate), "phi_start": phi_guess(inertial),
        "inertial": rate * D / math.sqrt(p_mean / RHO),
        "pressure": p_mean, "mean_pressure": float(pmean[used].mean()),
        "tau": float(tau[used].mean()), "tau_zx": float(tau_zx[used].mean()),
        "mu": float(tau[used].mean() / p_mean), "mu_error": float(mu_b.std()),
        "mu_mean_pressure": float(tau[used].mean() / pmean[used].mean()),
        "phi": float(phi[used].mean()), "phi_error": float(phi_b.std()),
        "seconds": seconds, "samples": a,
    }


def main(argv=None) -> dict:
    parser = arguments(__doc__.splitlines()[0], "mu_of_i")
    parser.add_argument("--quick", action="store_true",
                        help="three points (I = 0.03, 0.1, 0.3), 500 spheres, strain 0.5: seconds")
    parser.add_argument("--threads", type=int, default=2)
    args = parser.parse_args(argv)
    os.makedirs(args.out, exist_ok=True)
    inertial = np.array([0.03, 0.1, 0.3]) if args.quick else INERTIAL
    t0 = time.perf_counter()
    points = []
    for k, i in enumerate(inertial):
        pt = measure_point(float(i), args.quick, args.threads)
        np.savez_compressed(os.path.join(args.out, f"mu_of_i_{k}.npz"), samples=pt.pop("samples"),
                            columns=np.array(["strain", "sigma_xz", "sigma_zx", "p_zz", "p_mean", "phi"]))
        points.append(pt)
        print(f"I = {pt['inertial']:.2e} (target {i:.2e}, {pt['spheres']} spheres): mu = {pt['mu']:.3f} "
              f"+- {pt['mu_error']:.3f}, phi = {pt['phi']:.4f}, p = {pt['pressure']:.0f} Pa, "
              f"{pt['steps']} steps, {pt['seconds']:.0f} s", flush=True)
    i = np.array([pt["inertial"] for pt in points])
    mu = np.array([pt["mu"] for pt in points])
    mu_s, mu_2, i_0 = fit_mu(i, mu, [pt["mu_error"] for pt in points])
    a, phi_c = np.polyfit(i, [pt["phi"] for pt in points], 1)
    summary = {
        "points": points,
        "fit": {"mu_s": mu_s, "mu_2": mu_2, "I_0": i_0, "slope": (mu_2 - mu_s) / i_0,
                "I_0_at_bound": bool(min(abs(math.log(i_0 / b)) for b in I0_RANGE) < 1e-9)},
        "phi_fit": {"phi_c": float(phi_c), "a": float(-a)},
        "published": {"Jop2006": JOP},
        "pressure_target": PRESSURE, "kappa": KAPPA, "friction": FRICTION, "restitution": RESTITUTION,
        "diameter": D, "density": RHO, "kn": KN, "threads": args.threads,
        "seconds": time.perf_counter() - t0,
    }
    write_json(os.path.join(args.out, "mu_of_i.json"), summary)
    print(f"fit: mu_s = {mu_s:.3f}, mu_2 = {mu_2:.3f}, I_0 = {i_0:.3f}"
          f"{' (its bound)' if summary['fit']['I_0_at_bound'] else ''}, slope (mu_2 - mu_s) / I_0 = "
          f"{(mu_2 - mu_s) / i_0:.3f}; phi = {phi_c:.3f} - {-a:.3f} I; "
          f"{summary['seconds']:.0f} s")
    png = figure_path(args, "mu_of_i")
    if png:
        plot(args.out, png)
    return summary


def plot(out: str, png: str) -> None:
    """mu(I) with the fit and Jop et al.'s law; phi(I): from OUT/mu_of_i.json alone."""
    import json

    plt = pyplot()
    with open(os.path.join(out, "mu_of_i.json")) as f:
        s = json.load(f)
    pts = s["points"]
    i = np.array([p["inertial"] for p in pts])
    fine = np.logspace(math.log10(min(i.min(), 1e-3) / 1.5), math.log10(max(i.max(), 0.3) * 1.5), 200)
    fig, (left, right) = plt.subplots(1, 2, figsize=(10.5, 4.2))
    left.errorbar(i, [p["mu"] for p in pts], yerr=[p["mu_error"] for p in pts], fmt="o", color="C0",
                  capsize=3, label=r"tsubu, $\mu = \sigma_{xz} / (-\sigma_{zz})$")
    f = s["fit"]
    bound = " (its bound)" if f.get("I_0_at_bound") else ""
    left.plot(fine, mu_law(fine, f["mu_s"], f["mu_2"], f["I_0"]), color="C0",
              label=rf"fit: $\mu_s$={f['mu_s']:.3f}, $\mu_2$={f['mu_2']:.2f}, $I_0$={f['I_0']:.2f}{bound}")
    j = s["published"]["Jop2006"]
    left.plot(fine, mu_law(fine, j["mu_s"], j["mu_2"], j["I_0"]), "--", color="C3",
              label="Jop et al. 2006 (glass beads, incline)")
    left.set_xscale("log")
    left.set_xlabel("inertial number I")
    left.set_ylabel(r"$\mu = \tau / p$")
    left.set_title(rf"simple shear, friction {s['friction']}, e = {s['restitution']}, "
                   rf"$k_n/(pd)$ = {s['kappa']:.0e}", fontsize=9)
    left.legend(fontsize=8)
    phi = [p["phi"] for p in pts]
    right.errorbar(i, phi, yerr=[p["phi_error"] for p in pts], fmt="s", color="C2", capsize=3, label="tsubu")
    right.plot(fine, s["phi_fit"]["phi_c"] - s["phi_fit"]["a"] * fine, color="C2",
               label=rf"$\phi$ = {s['phi_fit']['phi_c']:.3f} $-$ {s['phi_fit']['a']:.3f} I")
    right.set_xscale("log")
    right.set_xlabel("inertial number I")
    right.set_ylabel(r"solid fraction $\phi$")
    right.legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, png)


if __name__ == "__main__":
    main()
