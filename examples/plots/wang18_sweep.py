"""Plot of the Wang18 sweeps (examples/wang18_fig14_mse_vs_g, wang18_fig22_cost_vs_g,
wang18_fig23_surface_samples, wang18_fig24_epsilon): the first CSV column is the swept
parameter; columns named e2_<component> go to a log-scale error panel, columns named
cost_<component> to a cost panel. Usage: wang18_sweep.py CSV PNG XLABEL COSTLABEL TITLE [logx]
(Debian's /usr/bin/python3 with matplotlib)."""
import csv
import sys

import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402


def main(csv_path, png, xlabel, costlabel, title, logx=False):
    with open(csv_path) as f:
        rows = list(csv.DictReader(f))
    keys = list(rows[0].keys())
    x = [float(r[keys[0]]) for r in rows]
    e2 = [k for k in keys if k.startswith('e2_')]
    cost = [k for k in keys if k.startswith('cost_')]
    panels = [(e2, 'per-pixel error e$^2$ (MSE - reference variance)', True), (cost, costlabel, False)]
    panels = [p for p in panels if p[0]]
    fig, axes = plt.subplots(1, len(panels), figsize=(5.5 * len(panels), 4.2), squeeze=False)
    for ax, (cols, ylabel, logy) in zip(axes[0], panels):
        for k in cols:
            ax.plot(x, [float(r[k]) for r in rows], 'o-', label=k.split('_', 1)[1])
        if logy:
            ax.set_yscale('log')
        if logx:
            ax.set_xscale('log')
        ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(png, dpi=110)


if __name__ == '__main__':
    if len(sys.argv) < 6:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4], sys.argv[5], len(sys.argv) > 6 and sys.argv[6] == 'logx')
