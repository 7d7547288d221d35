"""Plot of examples/guo21_fig8_phase (Guo21 Fig. 8): ensemble phase functions of a few particle
size distributions at 550 nm, linear and logarithmic angle axes.
Usage: guo21_fig8_phase.py CSV PNG (Debian's /usr/bin/python3 with matplotlib)."""
import csv
import sys

import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402


def main(csv_path, png):
    with open(csv_path) as f:
        rows = list(csv.reader(f))
    d = {k: [float(r[i]) for r in rows[1:]] for i, k in enumerate(rows[0])}
    fig, ax = plt.subplots(1, 2, figsize=(13, 4.5))
    for k in d:
        if k == 'theta_deg':
            continue
        for a in ax:
            a.plot(d['theta_deg'], d[k], lw=1, label=k.replace('phase_', '').replace('_550nm', ''))
    ax[0].set_yscale('log')
    ax[0].set_xlim(0, 180)
    ax[0].set_xlabel('theta [deg]')
    ax[1].set_xscale('log')
    ax[1].set_yscale('log')
    ax[1].set_xlabel('theta [deg] (log)')
    for a in ax:
        a.set_ylabel('phase function [1/sr], 550 nm')
        a.legend(fontsize=8)
    fig.suptitle('Guo21 Fig. 8: ensemble phase functions (ice, eta = 1.31)')
    fig.tight_layout()
    fig.savefig(png, dpi=110)


if __name__ == '__main__':
    main(sys.argv[1], sys.argv[2])
