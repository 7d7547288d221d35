"""Plot of examples/meng15_table2_ttuv: ttuv speedups over EPT per scene and technique (combined
and high order), ours beside Meng15 Table 2's. Usage: meng15_table2_ttuv.py CSV PNG (Debian's
/usr/bin/python3 with matplotlib)."""
import csv
import sys

import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def main(csv_path, png):
    with open(csv_path) as f:
        rows = [r for r in csv.DictReader(f) if r['technique'] != 'EPT']
    scenes = sorted(set(r['scene'] for r in rows), key=[r['scene'] for r in rows].index)
    techs = sorted(set(r['technique'] for r in rows), key=[r['technique'] for r in rows].index)
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.2))
    width = 0.8 / (2 * len(scenes))
    x = np.arange(len(techs))
    for k, (col, pcol, title) in enumerate([('speedup', 'paper_speedup', 'combined'),
                                            ('speedup_high', 'paper_speedup_high', 'high order')]):
        ax = axes[k]
        for i, s in enumerate(scenes):
            ours = [float(next(r[col] for r in rows if r['scene'] == s and r['technique'] == t)) for t in techs]
            paper = [float(next(r[pcol] for r in rows if r['scene'] == s and r['technique'] == t)) for t in techs]
            ax.bar(x + (2 * i) * width - 0.4 + width / 2, ours, width, label=s + ' (ours)')
            if any(p > 0 for p in paper):
                ax.bar(x + (2 * i + 1) * width - 0.4 + width / 2, paper, width, alpha=0.5,
                       label=s + ' (Meng15 Table 2)')
        ax.set_yscale('log')
        ax.set_xticks(x)
        ax.set_xticklabels(techs, rotation=15, fontsize=8)
        ax.set_title('ttuv speedup over EPT, ' + title)
        ax.axhline(1.0, color='k', lw=0.5)
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(png, dpi=110)


if __name__ == '__main__':
    main(sys.argv[1], sys.argv[2])
