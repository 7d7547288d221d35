"""Plot of examples/meng15_hybrid_convergence: ttuv speed-ups over EPT of each hybrid technique
(combined and high order), ours beside the range Meng15 Table 2 spans over its scenes (bar at the
geometric mean of the range, error bar = the range). Usage: meng15_hybrid_convergence.py CSV PNG
(Debian's /usr/bin/python3 with matplotlib)."""
import csv
import sys

import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def main(csv_path, png):
    with open(csv_path) as f:
        rows = list(csv.DictReader(f))[1:]  # the first row is EPT itself (speed-up 1)
    names = [r['technique'] for r in rows]
    x = np.arange(len(names))
    fig, ax = plt.subplots(1, 2, figsize=(11, 4))
    for k, (col, lo, hi, title) in enumerate([('speedup', 'paper_speedup_min', 'paper_speedup_max', 'combined'),
                                              ('speedup_high', 'paper_speedup_high_min', 'paper_speedup_high_max',
                                               'high order')]):
        ours = np.array([float(r[col]) for r in rows])
        pl = np.array([float(r[lo]) for r in rows])
        ph = np.array([float(r[hi]) for r in rows])
        gm = np.sqrt(pl * ph)
        ax[k].bar(x - 0.2, ours, 0.4, label='ours')
        ax[k].bar(x + 0.2, gm, 0.4, yerr=[gm - pl, ph - gm], label='Meng15 Table 2 (range over scenes)', alpha=0.6)
        ax[k].set_yscale('log')
        ax[k].set_xticks(x)
        ax[k].set_xticklabels(names, rotation=20, fontsize=8)
        ax[k].set_title('ttuv speedup over EPT, ' + title)
        ax[k].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(png, dpi=110)


if __name__ == '__main__':
    main(sys.argv[1], sys.argv[2])
