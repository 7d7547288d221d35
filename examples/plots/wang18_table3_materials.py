"""Plot of examples/wang18_table3_materials: per material, our equal-error speed-up of the
point-based method over the VPT beside Wang18 Table 3's time ratio against UPBP, and the split
of our error e^2 into the point-based noise and its bias. Usage: wang18_table3_materials.py CSV
PNG (Debian's /usr/bin/python3 with matplotlib)."""
import csv
import sys

import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def main(csv_path, png):
    with open(csv_path) as f:
        rows = list(csv.DictReader(f))
    names = [r['material'] for r in rows]
    x = np.arange(len(rows))
    ours = np.array([float(r['speedup_equal_error']) for r in rows])
    paper = np.array([float(r['paper_time_ratio']) for r in rows])
    e2 = np.array([float(r['e2']) for r in rows])
    noise = np.array([float(r['pb_noise']) for r in rows])
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.2))
    a.bar(x - 0.2, ours, 0.4, label='ours: equal-error speed-up vs VPT')
    a.bar(x + 0.2, paper, 0.4, label='Wang18 Table 3: UPBP time / offline time')
    a.axhline(1, color='k', lw=0.8)
    a.set_yscale('log')
    a.set_xticks(x, names)
    a.set_ylabel('speed-up')
    a.legend(fontsize=8)
    b.bar(x - 0.2, np.maximum(e2 - noise, 1e-12), 0.4, label='bias$^2$ (e$^2$ - noise)')
    b.bar(x + 0.2, noise, 0.4, label='point-based noise')
    b.set_yscale('log')
    b.set_xticks(x, names)
    b.set_ylabel('per-pixel error')
    b.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(png, dpi=110)


if __name__ == '__main__':
    main(sys.argv[1], sys.argv[2])
