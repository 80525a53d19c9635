"""Figure for docs/physics.md: the default tangential-history rule against the notes' literal
(1.14). A glass bead rests on a floor that shakes sideways, u(t) = U sin(2 pi f t), gently
enough for the bead to roll with it without slipping: the friction force must follow the
floor's acceleration, F = 2/7 m du/dt (rolling sphere), back and forth.

    python docs/figures/history_rules.py   # writes docs/figures/history_rules.png
"""
import pathlib

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import tsubu


def shake(rule: str, amplitude: float = 1e-3, frequency: float = 500.0, cycles: int = 3):
    glass = tsubu.Material(density=2500.0, kn=1e3, restitution=0.5, friction=0.5, tangential_damping=0.5)
    sim = tsubu.Simulation(gravity=(0, 0, -9.81), tangential_history=rule)
    r = 0.5e-3
    m = 2500.0 * 4 / 3 * np.pi * r**3
    sim.add_sphere((0, 0, r - m * 9.81 / 1e3), r, glass)
    floor = sim.add_plane(point=(0, 0, 0), normal=(0, 0, 1), material=glass)
    sim.run(steps=2000)  # settle
    t, force, expected = [], [], []
    t0 = sim.time
    while sim.time - t0 < cycles / frequency:
        phase = 2 * np.pi * frequency * (sim.time - t0)
        sim.set_plane_motion(floor, velocity=(amplitude * np.sin(phase), 0, 0))
        sim.run(steps=5)
        c = sim.contacts()
        t.append(sim.time - t0)
        force.append(c["force"][0, 0] if len(c["i"]) else 0.0)
        expected.append(2 / 7 * m * amplitude * 2 * np.pi * frequency * np.cos(phase))
    return np.array(t), np.array(force), np.array(expected), 0.5 * m * 9.81


def main():
    fig, ax = plt.subplots(2, 1, figsize=(7, 5), sharex=True)
    for axis, rule in zip(ax, ["rotate", "literal"]):
        t, f, expected, cap = shake(rule)
        axis.plot(t * 1e3, expected * 1e6, color="k", lw=2, alpha=0.4, label="2/7 m du/dt (rolling)")
        axis.plot(t * 1e3, f * 1e6, lw=1, label=f'tsubu, tangential_history="{rule}"')
        axis.axhline(cap * 1e6, color="grey", lw=0.5, ls=":")
        axis.axhline(-cap * 1e6, color="grey", lw=0.5, ls=":")
        axis.set_ylabel("friction force [µN]")
        axis.legend(fontsize=8, loc="upper right")
    ax[0].set_title("bead on a floor shaken sideways at 500 Hz (dotted: Coulomb limit μ m g)", fontsize=9)
    ax[1].set_xlabel("time [ms]")
    fig.tight_layout()
    out = pathlib.Path(__file__).with_suffix(".png")
    fig.savefig(out, dpi=110)
    print("wrote", out)


if __name__ == "__main__":
    main()
