"""Simulate a hammer campaign of the paper's case 1, identify M, K and the
damping matrix (MKR, Rayleigh, and the maximum-likelihood refinement with
its error bars), and plot records and results against the truth.

    python examples/simulate_identify.py [OUT.png] [--scenario FILE] [--noise F] [--seed S]

Run from the repository (the default scenario is scenarios/paper-case1.toml);
writes OUT.png (default simulate_identify.png) with matplotlib's Agg backend.
"""

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only, no display needed

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import frameid  # noqa: E402

DEFAULT_SCENARIO = Path(__file__).resolve().parents[2] / "scenarios" / "paper-case1.toml"


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", nargs="?", default="simulate_identify.png")
    parser.add_argument("--scenario", default=str(DEFAULT_SCENARIO))
    parser.add_argument("--noise", type=float, default=0.01, help="fraction of each channel's RMS")
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()

    camp, truth = frameid.simulate(args.scenario, noise=args.noise, seed=args.seed)
    res = frameid.identify(camp, collocated=(truth.hit_floor - 1, 0), refine=True)
    ref, unc = res.refined, res.uncertainty

    print(res)
    for w in res.warnings:
        print("warning:", w)
    print("f [Hz]   true", truth.frequencies_hz, "identified", res.frequencies_hz)
    print("M [kg]\n", res.mass, "\n+-\n", unc.mass_std)
    print("damping, refined [N s/m]\n", ref.damping, "\n+-\n", ref.damping_std)

    fig, axes = plt.subplots(2, 2, figsize=(11, 8))

    # Records of the first hit.
    t = np.arange(camp.samples) * camp.dt_s
    ax = axes[0, 0]
    for i, name in enumerate(camp.outputs):
        ax.plot(t, camp.acc[0, i], lw=0.8, label=name)
    ax.set(xlabel="time [s]", ylabel="acceleration [m/s²]", title=f"{camp.labels[0]}: accelerations")
    ax.set_xlim(0, min(t[-1], 10.0))
    ax.legend()
    axf = ax.inset_axes([0.62, 0.08, 0.35, 0.3])
    axf.plot(t, camp.force[0, 0], color="k", lw=0.8)
    hit_s = t[np.argmax(np.abs(camp.force[0, 0]))]
    axf.set_xlim(max(0.0, hit_s - 0.25), hit_s + 0.25)
    axf.set_title("force [N]", fontsize=8)
    axf.tick_params(labelsize=7)

    # Frequencies and damping ratios: truth, identified (jackknife error
    # bars), refined (Fisher error bars).
    ax = axes[0, 1]
    modes = np.arange(1, len(truth.frequencies_hz) + 1)
    ax.plot(modes, 100 * truth.damping_ratios, "ks", ms=9, mfc="none", label="truth")
    ax.errorbar(modes - 0.08, 100 * res.damping_ratios, yerr=100 * unc.damping_ratios_std, fmt="o", label="ERA/DC")
    ax.errorbar(
        modes + 0.08,
        [100 * m.damping_ratio for m in ref.modes],
        yerr=[100 * m.damping_ratio_std for m in ref.modes],
        fmt="^",
        label="refined",
    )
    for j, f in enumerate(truth.frequencies_hz):
        ax.annotate(f"{f:.3f} Hz", (modes[j], 100 * truth.damping_ratios[j]), textcoords="offset points", xytext=(8, 8))
    ax.set(xticks=modes, xlabel="mode", ylabel="damping ratio [%]", title="modes")
    ax.legend()

    # Matrix entries relative to the truth.
    def entries(m):
        n = m.shape[0]
        return np.array([m[i, j] for i in range(n) for j in range(i, n)])

    n = truth.mass.shape[0]
    labels = [f"{i + 1}{j + 1}" for i in range(n) for j in range(i, n)]
    x = np.arange(len(labels))
    ax = axes[1, 0]
    for k, (name, est, std, true) in enumerate(
        [
            ("M (MKR)", res.mass, unc.mass_std, truth.mass),
            ("K (MKR)", res.stiffness, unc.stiffness_std, truth.stiffness),
            ("M (refined)", ref.mass, ref.mass_std, truth.mass),
            ("K (refined)", ref.stiffness, ref.stiffness_std, truth.stiffness),
        ]
    ):
        scale = np.sqrt(np.outer(np.diag(true), np.diag(true)))
        ax.errorbar(
            x + 0.15 * (k - 1.5),
            entries((est - true) / scale),
            yerr=entries(std / scale),
            fmt="o",
            label=name,
        )
    ax.axhline(0, color="k", lw=0.8)
    ax.set(xticks=x, xticklabels=labels, xlabel="entry", ylabel="(est - true) / √(true_ii true_jj)", title="M and K")
    ax.legend(fontsize=8)

    ax = axes[1, 1]
    true = truth.damping
    scale = np.sqrt(np.outer(np.diag(true), np.diag(true)))
    ax.bar(x - 0.3, entries(true), 0.2, color="k", label="truth")
    ax.bar(x - 0.1, entries(res.damping_mkr), 0.2, label="MKR")
    ax.bar(x + 0.1, entries(res.damping_rayleigh), 0.2, label="Rayleigh")
    ax.bar(x + 0.3, entries(ref.damping), 0.2, yerr=entries(ref.damping_std), label="refined")
    ax.set(xticks=x, xticklabels=labels, xlabel="entry", ylabel="damping [N s/m]", title="damping matrix")
    ax.legend(fontsize=8)

    fig.suptitle(f"{truth.scenario}: {camp.hits} hits, {100 * args.noise:g} % noise, seed {args.seed}")
    fig.tight_layout()
    fig.savefig(args.out, dpi=110)
    print("wrote", args.out)


if __name__ == "__main__":
    main()
