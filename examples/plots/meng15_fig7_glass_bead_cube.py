"""Plot of examples/meng15_fig7_glass_bead_cube: MSE (against EPT: b^2 + V/n) and variance (V/n)
vs core seconds for EPT, EPT+VPT and EPT+VPT+DA (Meng15 Fig. 7 bottom); solid where measured
(n <= spp), dashed where it follows from the measured b^2, V and cost per bundle. Usage:
meng15_fig7_glass_bead_cube.py CSV PNG (Debian's /usr/bin/python3 with matplotlib)."""
import csv
import sys

import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402


def main(csv_path, png):
    with open(csv_path) as f:
        rows = list(csv.DictReader(f))
    techs = sorted(set(r['technique'] for r in rows), key=[r['technique'] for r in rows].index)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for k, (col, title) in enumerate([('mse', 'MSE vs EPT'), ('variance', 'variance')]):
        ax = axes[k]
        for i, t in enumerate(techs):
            rs = [r for r in rows if r['technique'] == t]
            color = 'C%d' % i
            for measured, style in (('1', '-'), ('0', '--')):
                pts = [r for r in rs if r['measured'] == measured]
                if measured == '0':
                    last = [r for r in rs if r['measured'] == '1'][-1:]
                    pts = last + pts
                ax.loglog([float(r['core_seconds']) for r in pts], [float(r[col]) for r in pts], style, color=color,
                          marker='o' if measured == '1' else None, label=t if measured == '1' else None)
        ax.set_xlabel('core seconds')
        ax.set_title(title + ' per pixel (glass-bead cube)')
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(png, dpi=110)


if __name__ == '__main__':
    main(sys.argv[1], sys.argv[2])
