"""Plot of examples/wang18_point_based: per case (thick, small sphere) the image mean of every
component (single, double, multiple, bounced, total), point-based beside the VPT reference with
its standard error, and the relative difference written above each pair.
Usage: wang18_point_based.py CSV PNG (Debian's /usr/bin/python3 with matplotlib)."""
import csv
import sys

import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def main(csv_path, png):
    with open(csv_path) as f:
        rows = list(csv.DictReader(f))
    cases = []
    for r in rows:
        if r['case'] not in cases:
            cases.append(r['case'])
    fig, axes = plt.subplots(1, len(cases), figsize=(5.5 * len(cases), 4.2), squeeze=False)
    for ax, case in zip(axes[0], cases):
        sel = [r for r in rows if r['case'] == case]
        names = [r['component'] for r in sel]
        x = np.arange(len(sel))
        pb = np.array([float(r['pb_mean']) for r in sel])
        ref = np.array([float(r['vpt_mean']) for r in sel])
        se = np.array([float(r['vpt_se']) for r in sel])
        rel = np.array([float(r['rel_diff']) for r in sel])
        ax.bar(x - 0.2, pb, 0.4, label='point-based (Eqs. 5-9)')
        ax.bar(x + 0.2, ref, 0.4, yerr=2 * se, capsize=3, label='VPT reference (2 s.e.)')
        for xi, top, d in zip(x, np.maximum(pb, ref), rel):
            ax.annotate(f'{100 * d:+.1f}%', (xi, top), ha='center', va='bottom', fontsize=8)
        ax.set_xticks(x, names)
        ax.set_ylabel('image mean radiance')
        ax.set_title(f'{case} sphere')
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(png, dpi=110)


if __name__ == '__main__':
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2])
