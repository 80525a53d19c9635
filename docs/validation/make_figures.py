"""Figures and error table of the Chung & Ooi (2011) validation (docs/validation/README.md).

Reruns the cases of tests/validation/test_chung_ooi.py with the same drivers
(tests/validation/chung_ooi.py), over the paper's full sweeps and finer ones, writes one figure per
test into docs/validation/ (test1.png .. test8.png: simulation points against the analytic curve or
the rigid-body limit) and prints the table of measured errors that README.md shows.

    PYTHONPATH=python python docs/validation/make_figures.py     # (or after pip install .)

Needs matplotlib (``pip install ".[bench]"``). Takes a few seconds.
"""

from __future__ import annotations

import math
import pathlib
import sys

HERE = pathlib.Path(__file__).resolve().parent
ROOT = HERE.parents[1]
sys.path.insert(0, str(ROOT / "tests" / "validation"))
try:
    import tsubu  # noqa: F401
except ImportError:  # a source checkout with the extension built in place
    sys.path.insert(0, str(ROOT / "python"))

import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import chung_ooi as co  # noqa: E402

ROWS: list[tuple[str, str, str, str, str]] = []  # test, quantity, reference, measured, tolerance
COLORS = ("C0", "C3")


def row(test, quantity, reference, measured, tolerance):
    ROWS.append((test, quantity, reference, measured, tolerance))


def pct(x):
    return f"{100 * x:.3f} %"


def save(fig, name):
    fig.tight_layout()
    fig.savefig(HERE / name, dpi=110)
    plt.close(fig)


# ---- tests 1 and 2 -----------------------------------------------------------------------------
def normal_impacts(test: int, spec: dict, kind: str, t_unit: float, t_label: str):
    fig, (ax_t, ax_d) = plt.subplots(1, 2, figsize=(10, 4))
    for color, name in zip(COLORS, spec["materials"]):
        rec = co.record_normal_impact(kind, name, spec["radius"], spec["speed"], spec["restitution"],
                                      spec["friction"])
        err = co.hertz_errors(rec)
        t, d, f = co.hertz_curve(rec["m"], rec["r"], rec["estar"], rec["v"])
        ax_t.plot(t / t_unit, f / 1e3, color=color, lw=1, label=f"{name}: Hertz")
        ax_t.plot(rec["t"] / t_unit, rec["force"] / 1e3, "o", ms=3, mfc="none", color=color,
                  label=f"{name}: tsubu, dt = t_c/100")
        ax_d.plot(d * 1e6, f / 1e3, color=color, lw=1)
        ax_d.plot(rec["overlap"] * 1e6, rec["force"] / 1e3, "o", ms=3, mfc="none", color=color)
        for key, label in (("peak_force", "peak force"), ("peak_overlap", "peak overlap"),
                           ("duration", "contact duration")):
            row(f"{test} {name}", label, "Hertz", f"{100 * err[key]:+.4f} %", "0.5 %")
        row(f"{test} {name}", "F(delta) of every step", "Hertz", f"{err['curve']:.1e} (relative)", "1e-12")
        row(f"{test} {name}", "rebound speed / impact speed - 1", "0 (e = 1)", f"{err['rebound']:.1e}", "1e-4")
    ax_t.set_xlabel(t_label)
    ax_t.set_ylabel("normal force [kN]")
    ax_d.set_xlabel("overlap [um]")
    ax_d.set_ylabel("normal force [kN]")
    ax_t.legend(fontsize=8)
    where = "two spheres, +-10 m/s" if kind == "pair" else "sphere on a rigid plane, 0.2 m/s"
    fig.suptitle(f"Chung & Ooi test {test}: elastic normal impact, {where}")
    save(fig, f"test{test}.png")


# ---- test 3 --------------------------------------------------------------------------------------
def test3():
    spec = co.TEST3
    fig, (ax, ax_err) = plt.subplots(1, 2, figsize=(10, 4))
    e_in = np.round(np.arange(0.05, 1.0001, 0.05), 2)
    ax.plot([0, 1], [0, 1], "k-", lw=0.8, label="e_out = e_in")
    markers = {"signed": "o", "repulsive": "s"}
    for color, name in zip(COLORS, spec["materials"]):
        for hf in ("signed", "repulsive"):
            out = [co.wall_impact(name, spec["radius"], spec["speed"], restitution=e, hertz_force=hf)["vn1"]
                   / spec["speed"] for e in e_in]
            ax.plot(e_in, out, markers[hf], mfc="none", color=color, ms=5, label=f"{name}, {hf}")
    ax.set_xlabel("restitution asked, e_in")
    ax.set_ylabel("restitution measured, e_out")
    ax.legend(fontsize=8)
    ax.set_title("dt = t_c/100")
    # error against dt (the impact is self-similar: both materials give the same numbers)
    for hf, ls in (("signed", "-"), ("repulsive", "--")):
        for n, color in zip((50, 100, 200, 400), ("C2", "C0", "C1", "C3")):
            err = [abs(co.wall_impact("al_oxide", spec["radius"], spec["speed"], restitution=e, hertz_force=hf,
                                      steps_per_contact=n)["vn1"] / spec["speed"] - e) for e in e_in[:-1]]
            ax_err.semilogy(e_in[:-1], err, ls, marker=".", color=color, label=f"{hf}, t_c/{n}")
    ax_err.axhline(1e-3, color="k", lw=0.8)
    ax_err.set_xlabel("e_in")
    ax_err.set_ylabel("|e_out - e_in|")
    ax_err.legend(fontsize=7, ncol=2)
    ax_err.set_title("error against dt (Al oxide; cast iron is the same); tests: < 1e-3 at t_c/200", fontsize=9)
    fig.suptitle("Chung & Ooi test 3: restitution out against restitution in (Al oxide, cast iron, 3.9 m/s)")
    save(fig, "test3.png")
    for hf in ("signed", "repulsive"):
        for n in (100, 200):
            worst = max(abs(co.wall_impact(name, spec["radius"], spec["speed"], restitution=e, hertz_force=hf,
                                           steps_per_contact=n)["vn1"] / spec["speed"] - e)
                        for name in spec["materials"] for e in spec["restitutions"])
            row("3", f"max |e_out - e_in|, {hf}, t_c/{n}, e_in = 0.2..1", "e_in", f"{worst:.1e}",
                "1e-3" if n == 200 else "(not tested)")


# ---- oblique impacts: shared bookkeeping ---------------------------------------------------------
def gross_errors(results, ratio):
    """Largest |J_t/(mu J_abs) - 1| over the gross-slip results (psi > 1)."""
    errs = [abs(co.friction_impulse_ratio(r) / ratio - 1.0) for r in results if co.normalised_slip(r) > 1.0]
    return max(errs) if errs else float("nan")


def test4():
    spec = co.TEST4
    mu, e, r, v = spec["friction"], spec["restitution"], spec["radius"], spec["speed"]
    fig, axes = plt.subplots(1, 3, figsize=(14, 4))
    fine = np.arange(1.0, 89.5, 1.0)
    a = np.radians(fine)
    vn, vt = v * np.cos(a), v * np.sin(a)
    slide = mu * (1 + e) * vn
    gross = vt > 3.5 * slide
    axes[0].plot(fine, np.where(gross, 1 - slide / vt, 5 / 7), "k-", lw=1, label="rigid body")
    axes[1].plot(fine, np.where(gross, 2.5 * slide, 5 / 7 * vt) / r, "k-", lw=1)
    axes[2].plot(fine, np.degrees(np.arctan(np.where(gross, (np.tan(a) - 3.5 * mu * (1 + e)) / e, 0.0))), "k-", lw=1)
    worst = dict(j=0.0, et=0.0, w=0.0, ang=0.0)
    for color, name in zip(COLORS, spec["materials"]):
        for rule, mk in (("frozen", "o"), ("truncate", "x")):
            res = [co.wall_impact(name, r, v * math.cos(t), v * math.sin(t), restitution=e, friction=mu,
                                  slip_rule=rule) for t in a]
            et = [q["vt1"] / q["vt0"] for q in res]
            w = [q["wy1"] for q in res]
            ang = [math.degrees(math.atan(q["vc1"] / q["vn1"])) for q in res]
            lab = f"{name}, {rule}"
            axes[0].plot(fine, et, mk, ms=3.5, mfc="none", color=color, label=lab)
            axes[1].plot(fine, w, mk, ms=3.5, mfc="none", color=color)
            axes[2].plot(fine, ang, mk, ms=3.5, mfc="none", color=color)
            if rule == "frozen":
                ratio = co.absolute_impulse_ratio(e)
                paper = [co.wall_impact(name, r, v * math.cos(math.radians(t)), v * math.sin(math.radians(t)),
                                        restitution=e, friction=mu) for t in spec["angles"]]
                worst["j"] = max(worst["j"], gross_errors(paper, ratio))
                for q, t in zip(paper, spec["angles"]):
                    if co.normalised_slip(q) > 1.0:
                        tt = math.radians(t)
                        s = mu * ratio * (1 + e) * q["vn0"]
                        worst["et"] = max(worst["et"], abs(q["vt1"] / q["vt0"] - (1 - s / q["vt0"])))
                        worst["w"] = max(worst["w"], abs(q["wy1"] * r / (2.5 * s) - 1))
                        exp = math.degrees(math.atan((math.tan(tt) - 3.5 * mu * ratio * (1 + e)) / e))
                        worst["ang"] = max(worst["ang"], abs(math.degrees(math.atan(q["vc1"] / q["vn1"])) - exp))
    row("4", "J_t/(mu J_abs) - 1, gross slip (35-85 deg)", "rigid body", pct(worst["j"]), "2 %")
    row("4", "tangential restitution e_t, gross slip", "1 - mu(1+e)/tan(theta)", f"{worst['et']:.1e} (absolute)",
        "2 % of mu(1+e)/tan(theta)")
    row("4", "rebound spin, gross slip", "5/2 mu (1+e) v_n / r", pct(worst["w"]), "2 % + delta_max/2r")
    row("4", "rebound angle of the contact point, gross slip", "rigid body", f"{worst['ang']:.3f} deg", "0.75 deg")
    axes[0].axvline(math.degrees(math.atan(3.5 * mu * (1 + e))), color="0.6", lw=0.8, ls=":")
    axes[0].set_ylabel("tangential restitution v_t'/v_t")
    axes[1].set_ylabel("rebound spin [rad/s]")
    axes[2].set_ylabel("rebound angle of the contact point [deg]")
    for ax in axes:
        ax.set_xlabel("incidence from the normal [deg]")
    axes[0].legend(fontsize=8)
    fig.suptitle("Chung & Ooi test 4: oblique impact at 3.9 m/s, e = 0.98, mu = 0.092 "
                 "(dotted: 7/2 mu (1+e) threshold)")
    save(fig, "test4.png")


def test5():
    spec = co.TEST5
    mu, e, r, vn = spec["friction"], spec["restitution"], spec["radius"], spec["normal_speed"]
    fig, (ax, ax_w) = plt.subplots(1, 2, figsize=(11, 4.2))
    nia = np.linspace(0.0, 14.5, 300)
    ax.plot(nia, np.where(nia > 7, nia - 7, 0.0), "k-", lw=1, label="rigid body")
    ax_w.plot(nia, np.where(nia > 7, 5.0, 5 / 7 * nia), "k-", lw=1)
    sweep = np.concatenate([spec["tangential_speeds"], np.linspace(0.05, 21.5, 80)])
    sweep.sort()
    worst = dict(j=0.0, nra=0.0, nrav=0.0)
    for color, name in zip(COLORS, spec["materials"]):
        limit = co.no_slip_exit_slip(name, r, vn)
        ax.plot(nia[nia < 3], limit * nia[nia < 3], ":", color=color, lw=1.2,
                label=f"{name}: Mindlin no-slip limit, v_c'/v_c = {limit:.3f}")
        for rule, mk in (("frozen", "o"), ("truncate", "x")):
            res = [co.wall_impact(name, r, vn, vt, restitution=e, friction=mu, slip_rule=rule) for vt in sweep]
            x = [q["vt0"] / (mu * vn) for q in res]
            ax.plot(x, [q["vc1"] / (mu * q["vn1"]) for q in res], mk, ms=3.5, mfc="none", color=color,
                    label=f"{name}, {rule}")
            ax_w.plot(x, [q["wy1"] * r / (mu * vn) for q in res], mk, ms=3.5, mfc="none", color=color)
            paper = [q for q in res if q["vt0"] in spec["tangential_speeds"]]
            worst["j"] = max(worst["j"], gross_errors(paper, 1.0))
            for q in paper:
                if q["vt0"] / (mu * vn) > 7:
                    worst["nra"] = max(worst["nra"], abs(q["vc1"] / (mu * q["vn1"]) - (q["vt0"] / (mu * vn) - 7)))
                    worst["nrav"] = max(worst["nrav"], abs(q["wy1"] * r / (mu * vn) / 5 - 1))
        # the no-slip limit against the DEM at mu = 1e4
        x = {n: (lambda q: q["vc1"] / q["vc0"])(co.wall_impact(name, r, vn, 0.01 * vn, restitution=1.0, friction=1e4,
                                                               steps_per_contact=n)) for n in (100, 200, 400)}
        row("5", f"no-slip limit v_c'/v_c, {name} (RK4: {limit:.4f})", "Mindlin spring alone",
            f"{x[100] - limit:+.4f} / {x[200] - limit:+.4f} / {x[400] - limit:+.4f} at t_c/100, /200, /400; "
            f"Richardson {2 * x[200] - x[100] - limit:+.1e}", "Richardson 2e-3; first order")
    row("5", "J_t/(mu J_n) - 1, gross slip (v_t/(mu v_n) > 7), both slip rules", "rigid body", pct(worst["j"]), "2 %")
    row("5", "normalised rebound angle, gross slip", "v_t/(mu v_n) - 7", f"{worst['nra']:.3f} (absolute)",
        "0.14 + 5 delta_max/2r")
    row("5", "normalised spin, gross slip", "5", pct(worst["nrav"]), "2 % + delta_max/2r")
    ax.set_xlabel("v_t / (mu v_n)")
    ax.set_ylabel("v_c' / (mu v_n')  (contact point)")
    ax_w.set_xlabel("v_t / (mu v_n)")
    ax_w.set_ylabel("omega' r / (mu v_n)")
    ax.legend(fontsize=7)
    fig.suptitle("Chung & Ooi test 5: v_n = 5 m/s, v_t = 0.1..21 m/s, e = 1, mu = 0.3 (steel, polyethylene)")
    save(fig, "test5.png")


def spin_sweep_axes(ax, ax_tan, mu, e, ratio_signed):
    x = np.linspace(0.05, 25, 500)
    ax.plot(x, np.minimum(x - 1, 0.0), "k-", lw=1, label="rigid body (J_t = mu J_n)")
    ax.plot(x, np.minimum(x * ratio_signed - 1, 0.0), "k--", lw=1, label="rigid body, J_t = mu J_abs (signed)")
    if ax_tan is not None:
        t = np.linspace(0, 11, 300)
        ax_tan.plot(t, np.maximum((t - 3.5 * mu * (1 + e)) / e, 0.0), "k-", lw=1)
        ax_tan.plot(t, np.maximum((t - 3.5 * mu * (1 + e) * ratio_signed) / e, 0.0), "k--", lw=1)


def test6():
    spec = co.TEST6
    mu, e, r, vn = spec["friction"], spec["restitution"], spec["radius"], spec["normal_speed"]
    ratio = co.absolute_impulse_ratio(e)
    fig, axes = plt.subplots(2, 2, figsize=(11, 8))
    spins = np.unique(np.concatenate([spec["spins"], np.geomspace(0.15, 22, 60)]))
    for k, rule in enumerate(("frozen", "truncate")):
        ax, ax_tan = axes[k]
        spin_sweep_axes(ax, ax_tan, mu, e, ratio)
        for color, name in zip(COLORS, spec["materials"]):
            for hf, mk in (("signed", "o"), ("repulsive", "x")):
                res = [co.wall_impact(name, r, vn, 0.0, spin=w, restitution=e, friction=mu, hertz_force=hf,
                                      slip_rule=rule) for w in spins]
                ax.plot([3.5 * mu * (1 + e) * vn / (r * w) for w in spins], [-q["vc1"] / q["vc0"] for q in res],
                        mk, ms=3.5, mfc="none", color=color, label=f"{name}, {hf}")
                ax_tan.plot([r * w / vn for w in spins], [q["vc1"] / q["vn1"] for q in res], mk, ms=3.5,
                            mfc="none", color=color)
                paper = [q for q, w in zip(res, spins) if w in spec["spins"]]
                rt = ratio if hf == "signed" else 1.0
                errs = [abs(-q["vc1"] / q["vc0"] - (3.5 * mu * (1 + e) * vn / q["vc0"] * rt - 1))
                        for q in paper if co.normalised_slip(q) > 1]
                row("6", f"J_t/(mu J_abs) - 1, gross slip, {name}, {hf}, {rule}",
                    "rigid body" + (" with J_abs = 1.067 J_n" if hf == "signed" else ""),
                    pct(gross_errors(paper, rt)) + f"; beta: {max(errs):.4f}", "2 %")
                if hf == "signed":
                    dev = max(co.friction_impulse_ratio(q) - 1 for q in paper if co.normalised_slip(q) > 1)
                    row("6", f"J_t/(mu J_n) - 1, gross slip, {name}, signed, {rule}", "rigid body (J_n)",
                        pct(dev), "(> 3 %: the pull's share)")
        ax.set_xscale("log")
        ax.set_xlabel("X = 7/2 mu (1+e) v_n / (r omega_0)")
        ax.set_ylabel("beta = -v_c'/(r omega_0)")
        ax.set_title(f"slip_rule = {rule!r}")
        ax_tan.set_xlabel("r omega_0 / v_n  (tangent of the incidence of the contact point)")
        ax_tan.set_ylabel("v_c' / v_n'  (tangent of its rebound)")
        ax_tan.set_title(f"slip_rule = {rule!r}")
    axes[0][0].legend(fontsize=7)
    fig.suptitle("Chung & Ooi test 6: spinning sphere on a rigid plane, v_n = 0.2 m/s, e = 0.5, mu = 0.4 "
                 "(Al alloy, nylon)")
    save(fig, "test6.png")


def test7():
    spec = co.TEST7
    mu, e, r, v = spec["friction"], spec["restitution"], spec["radius"], spec["speed"]
    ratio = co.absolute_impulse_ratio(e)
    fig, (ax_w, ax_v, ax_b) = plt.subplots(1, 3, figsize=(14, 4))
    spins = np.array(spec["spins"])
    ax_w.plot(spins, spins, "k-", lw=1, label="exact: omega' = omega_0")
    ax_v.axhline(0.0, color="k", lw=1, label="exact: v_t' = 0")
    worst_w = worst_v = 0.0
    for color, name in zip(COLORS, spec["materials"]):
        res = [co.pair_impact(name, r, v, w, -w, e, mu) for w in spins]
        ax_w.plot(spins, [q["w1"][0] for q in res], "o", mfc="none", color=color, label=name)
        ax_v.plot(spins, [q["v1"][1] for q in res], "o", mfc="none", color=color, label=name)
        worst_w = max([worst_w] + [abs(q["w1"][0] / w - 1) for q, w in zip(res, spins)])
        worst_v = max([worst_v] + [abs(q["v1"][1]) for q in res])
    row("7", "opposite spins: max |omega'/omega_0 - 1|, max |v_t'|", "1, 0 (no slip at the contact)",
        f"{worst_w:.1e}, {worst_v:.1e} m/s", "1e-12")
    spin_sweep_axes(ax_b, None, mu, e, ratio)
    for color, name in zip(COLORS, spec["materials"]):
        for hf, mk in (("signed", "o"), ("repulsive", "x")):
            res = [co.pair_impact(name, r, v, w, w, e, mu, hertz_force=hf) for w in np.geomspace(0.15, 22, 40)]
            ax_b.plot([3.5 * mu * (1 + e) * q["vn0"] / q["vc0"] for q in res], [-q["vc1"] / q["vc0"] for q in res],
                      mk, ms=3.5, mfc="none", color=color, label=f"{name}, {hf}")
            paper = [co.pair_impact(name, r, v, w, w, e, mu, hertz_force=hf) for w in spins]
            row("7", f"equal spins (beyond the paper): J_t/(mu J_abs) - 1, gross slip, {name}, {hf}", "rigid body",
                pct(gross_errors(paper, ratio if hf == "signed" else 1.0)), "2 %")
    ax_w.set_xlabel("omega_0 [rad/s]")
    ax_w.set_ylabel("omega' of sphere 1 [rad/s]")
    ax_v.set_xlabel("omega_0 [rad/s]")
    ax_v.set_ylabel("v_t' of sphere 1 [m/s]")
    ax_v.set_ylim(-0.01, 0.01)
    ax_b.set_xscale("log")
    ax_b.set_xlabel("X = 7/2 mu (1+e) v_n / v_c  (v_c = 2 r omega_0)")
    ax_b.set_ylabel("-v_c'/v_c")
    ax_b.set_title("equal spins (beyond the paper)", fontsize=9)
    ax_w.legend(fontsize=8)
    ax_b.legend(fontsize=7)
    fig.suptitle("Chung & Ooi test 7: two spheres at -+0.2 m/s with spins +-omega_0 (Al alloy, copper), e = 0.5, mu = 0.4")
    save(fig, "test7.png")


def test8():
    spec = co.TEST8
    mu, e, r, v = spec["friction"], spec["restitution"], spec["radius"], spec["speed"]
    ratio = co.absolute_impulse_ratio(e)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    spins = np.unique(np.concatenate([spec["spins"], np.geomspace(0.15, 22, 40)]))
    for ax, name in zip(axes, spec["materials"]):
        spin_sweep_axes(ax, None, mu, e, ratio)
        for case, color in (("A", "C0"), ("B", "C3")):
            for hf, mk in (("signed", "o"), ("repulsive", "x")):
                res = [co.pair_impact(name, r, v, -w, 0.0, e, mu, radius2=spec["radius_ratio"] * r,
                                      density_factor2=spec["density_ratio"], speed2=0.0,
                                      modulus_factor2=1000.0 if case == "A" else 1.0, hertz_force=hf) for w in spins]
                ax.plot([3.5 * mu * (1 + e) * q["vn0"] / abs(q["vc0"]) for q in res],
                        [-q["vc1"] / q["vc0"] for q in res], mk, ms=3.5, mfc="none", color=color,
                        label=f"case {case}, {hf}")
                paper = [q for q, w in zip(res, spins) if w in spec["spins"]]
                row("8", f"J_t/(mu J_abs) - 1, gross slip, {name}, case {case}, {hf}", "rigid body",
                    pct(gross_errors(paper, ratio if hf == "signed" else 1.0)), "2 %")
        plane = [co.wall_impact(name, r, v, 0.0, spin=w, restitution=e, friction=mu) for w in spins]
        ax.plot([3.5 * mu * (1 + e) * v / (r * w) for w in spins], [-q["vc1"] / q["vc0"] for q in plane], "-",
                color="0.6", lw=1, label="test 6 (rigid plane), signed")
        ax.set_xscale("log")
        ax.set_xlabel("X = 7/2 mu (1+e) v_n / (r omega_0)")
        ax.set_ylabel("beta = -v_c'/(r omega_0)")
        ax.set_title(f"{name}: A = large sphere 1000 x stiffer, B = same material", fontsize=9)
    axes[0].legend(fontsize=7)
    fig.suptitle("Chung & Ooi test 8: sphere r onto a sphere 5 r of 1000 x the density, 0.2 m/s, e = 0.5, mu = 0.4")
    save(fig, "test8.png")


def main():
    normal_impacts(1, co.TEST1, "pair", 1e-6, "time [us]")
    normal_impacts(2, co.TEST2, "wall", 1e-3, "time [ms]")
    test3()
    test4()
    test5()
    test6()
    test7()
    test8()
    print("| Test | Quantity | Reference | Measured | Tolerance in the tests |")
    print("|---|---|---|---|---|")
    for r in ROWS:
        print("| " + " | ".join(c.replace("|", "\\|") for c in r) + " |")


if __name__ == "__main__":
    main()
