"""Plot of examples/meng15_table1_grain_stats (Meng15 Table 1): the scatterometer statistics of
our procedural grains beside the paper's, one bar chart per statistic.
Usage: meng15_table1_grain_stats.py CSV PNG (Debian's /usr/bin/python3 with matplotlib)."""
import csv
import sys

import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def read_csv(path):
    with open(path) as f:
        rows = list(csv.reader(f))
    cols = {k: [] for k in rows[0]}
    for row in rows[1:]:
        for k, v in zip(rows[0], row):
            try:
                cols[k].append(float(v))
            except ValueError:
                cols[k].append(v)
    return cols


def main(csv_path, png):
    d = read_csv(csv_path)
    keys = [('lambda_delta', r'$\lambda_\delta$'), ('lambda_s', r'$\lambda_s$'), ('alpha_s', r'$\alpha_s$'),
            ('beta', r'$\beta$')]
    fig, axs = plt.subplots(1, 4, figsize=(15, 3.8))
    x = np.arange(len(d['grain']))
    for ax, (k, lab) in zip(axs, keys):
        ax.bar(x - 0.2, d[k + '_paper'], 0.4, label='Meng15 Table 1', color='0.6')
        ax.bar(x + 0.2, d[k], 0.4, label='ours (procedural grains)', color='C0')
        ax.set_xticks(x)
        ax.set_xticklabels(d['paper_grain'], rotation=45, ha='right', fontsize=8)
        ax.set_title(lab)
    axs[0].legend(fontsize=7)
    fig.suptitle('Meng15 Table 1: scatterometer statistics, paper vs ours')
    fig.tight_layout()
    fig.savefig(png, dpi=110)


if __name__ == '__main__':
    main(sys.argv[1], sys.argv[2])
