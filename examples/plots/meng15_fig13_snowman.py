"""Plot of examples/meng15_fig13_snowman: per scale (1 m, 10 cm snowman) the equal-time CPU seconds
and the ttuv speed-ups over EPT of EPT+VPT and EPT+VPT+DA, ours beside Meng15 Table 2's
(SNOWMAN LG. / SM., P_a = 1). Usage: meng15_fig13_snowman.py CSV PNG (Debian's /usr/bin/python3
with matplotlib)."""
import csv
import sys

import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def main(csv_path, png):
    with open(csv_path) as f:
        rows = list(csv.DictReader(f))
    scales = sorted(set(r['scale'] for r in rows), key=[r['scale'] for r in rows].index)
    techs = sorted(set(r['technique'] for r in rows), key=[r['technique'] for r in rows].index)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    x = np.arange(len(techs))
    w = 0.2
    for i, s in enumerate(scales):
        sec = [float(next(r['cpu_seconds'] for r in rows if r['scale'] == s and r['technique'] == t)) for t in techs]
        axes[0].bar(x + (i - 0.5) * 2 * w, sec, 2 * w * 0.9, label=s)
        ours = [float(next(r['speedup'] for r in rows if r['scale'] == s and r['technique'] == t)) for t in techs]
        paper = [float(next(r['paper_speedup'] for r in rows if r['scale'] == s and r['technique'] == t)) for t in techs]
        axes[1].bar(x + (2 * i - 1.5) * w, ours, w, label=s + ' (ours)')
        axes[1].bar(x + (2 * i - 0.5) * w, paper, w, alpha=0.5, label=s + ' (Table 2)')
    axes[0].set_title('equal-time budget: CPU seconds per render')
    axes[0].set_ylabel('CPU s')
    axes[1].set_title('ttuv speed-up over EPT')
    axes[1].set_yscale('log')
    for ax in axes:
        ax.set_xticks(x)
        ax.set_xticklabels(techs)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(png, dpi=110)


if __name__ == '__main__':
    main(sys.argv[1], sys.argv[2])
