"""Figure for docs/roughness.md: rebound angles of 10,000 glass beads thrown at a rough wall,
tsubu against a Monte-Carlo of the model's own formulas.

Each bead (r = 0.5 mm, kn = 1000 N/m, frictionless, e = 1, no gravity) meets the floor at
0.1 m/s, gamma = 30 or 10 degrees from the wall plane; the beads are 5 mm apart, so the 10,000
impacts are independent. The wall has roughness sigma = 0 (smooth), 5, 10 or 20 degrees
(normal distribution, shadow rule "reject"). The histograms are tsubu's; the black line is a
numpy Monte-Carlo (100,000 samples) of the same model: facet normal n' = cos dG n + sin dG
(sin psi n1 + cos psi n2), facets with v . n' >= 0 redrawn, rigid reflection
v' = v - (1 + e)(v . n') n', and a new facet while v' still points into the wall.

    python docs/figures/roughness_rebound.py   # writes docs/figures/roughness_rebound.png
"""
import math
import pathlib

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import tsubu

R = 0.5e-3
SPEED = 0.1
N = 10_000
N_MC = 100_000


def dem(sigma_deg, gamma_deg, seed=1):
    wall = tsubu.Material(density=2500.0, kn=1e3, restitution=1.0, friction=0.0,
                          roughness=sigma_deg)
    bead = tsubu.Material(density=2500.0, kn=1e3, restitution=1.0, friction=0.0)
    sim = tsubu.Simulation(gravity=(0, 0, 0), seed=seed)
    g = math.radians(gamma_deg)
    v0 = SPEED * np.array([math.cos(g), 0.0, -math.sin(g)])
    x = np.zeros((N, 3))
    x[:, 0] = np.arange(N) * 10 * R
    x[:, 2] = R + 1e-6
    sim.add_spheres(x, R, bead, velocities=np.tile(v0, (N, 1)))
    sim.add_plane(point=(0, 0, 0), normal=(0, 0, 1), material=wall)
    for _ in range(40):
        sim.run(steps=100)
        if len(sim.contacts()["i"]) == 0 and np.all(sim.velocities[:, 2] > 0):
            break
    return sim.velocities


def monte_carlo(sigma_deg, gamma_deg, rng, e=1.0):
    n = np.array([0.0, 0.0, 1.0])
    n1 = np.array([0.0, 1.0, 0.0])  # normalise(n x x-axis): the engine's basis rule for n = z
    n2 = np.cross(n, n1)
    sigma = math.radians(sigma_deg)
    g = math.radians(gamma_deg)
    v = np.tile(SPEED * np.array([math.cos(g), 0.0, -math.sin(g)]), (N_MC, 1))
    active = np.arange(N_MC)
    while active.size:
        facet = np.tile(n, (active.size, 1))
        todo = np.arange(active.size)
        for _ in range(64):
            if todo.size == 0:
                break
            dg = rng.normal(0.0, sigma, todo.size)
            psi = rng.uniform(0.0, 2.0 * math.pi, todo.size)
            npr = (np.cos(dg)[:, None] * n
                   + np.sin(dg)[:, None] * (np.sin(psi)[:, None] * n1 + np.cos(psi)[:, None] * n2))
            ok = (np.abs(dg) < 0.5 * math.pi) & (np.einsum("ij,ij->i", v[active[todo]], npr) < 0)
            facet[todo[ok]] = npr[ok]
            todo = todo[~ok]
        vn = np.einsum("ij,ij->i", v[active], facet)
        v[active] -= (1.0 + e) * vn[:, None] * facet
        active = active[v[active] @ n < 0]
    return v


def rebound_angle(v):
    return np.degrees(np.arctan2(v[:, 2], np.hypot(v[:, 0], v[:, 1])))


def main():
    sigmas = (0.0, 5.0, 10.0, 20.0)
    gammas = (30.0, 10.0)
    rng = np.random.default_rng(2025)
    fig, axes = plt.subplots(len(gammas), len(sigmas), figsize=(12, 5.6), sharex=True)
    bins = np.arange(-1.0, 92.0, 2.0)  # 2-degree bins centred on even angles (10, 30 included)
    centres = 0.5 * (bins[1:] + bins[:-1])
    for row, gamma in enumerate(gammas):
        for col, sigma in enumerate(sigmas):
            ax = axes[row, col]
            d = rebound_angle(dem(sigma, gamma))
            m = rebound_angle(monte_carlo(sigma, gamma, rng))
            ax.hist(d, bins=bins, density=True, color="tab:blue", alpha=0.55,
                    label=f"tsubu, {N:,} impacts")
            h, _ = np.histogram(m, bins=bins, density=True)
            ax.plot(centres, h, color="k", lw=1.2, drawstyle="steps-mid",
                    label="Monte-Carlo of the model")
            ax.axvline(gamma, color="tab:red", lw=0.8, ls=":", label="incidence / specular angle")
            ax.text(0.97, 0.95,
                    f"tsubu  {d.mean():5.2f} ± {d.std():5.2f}°\n"
                    f"MC     {m.mean():5.2f} ± {m.std():5.2f}°",
                    transform=ax.transAxes, ha="right", va="top", fontsize=7.5, family="monospace")
            title = "smooth (σ = 0)" if sigma == 0 else f"σ = {sigma:g}°"
            ax.set_title(f"γ = {gamma:g}°, {title}", fontsize=9)
            if row == len(gammas) - 1:
                ax.set_xlabel("rebound angle from the wall plane [°]")
            if col == 0:
                ax.set_ylabel("probability density [1/°]")
            ax.set_xlim(0, 90)
            ax.tick_params(labelsize=8)
    axes[0, 0].legend(fontsize=7, loc="center right")
    fig.suptitle("Rebound angles off a rough wall (normal ΔΓ ~ N(0, σ), shadow rule \"reject\", "
                 "e = 1, frictionless, 0.1 m/s); text: mean ± std", fontsize=10)
    fig.tight_layout()
    out = pathlib.Path(__file__).with_suffix(".png")
    fig.savefig(out, dpi=110)
    print("wrote", out)


if __name__ == "__main__":
    main()
