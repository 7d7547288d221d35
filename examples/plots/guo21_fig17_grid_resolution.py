"""Plot of examples/guo21_fig17_grid_resolution (Guo21 Fig. 17): render CPU time against the
grid's mean particles per voxel. Usage: guo21_fig17_grid_resolution.py CSV PNG (Debian's
/usr/bin/python3 with matplotlib)."""
import csv
import sys

import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402


def main(csv_path, png):
    with open(csv_path) as f:
        rows = list(csv.DictReader(f))
    ppv = [float(r['particles_per_voxel']) for r in rows]
    sec = [float(r['cpu_seconds']) for r in rows]
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot(ppv, sec, 'o-', label='ours (discrete medium)')
    i = min(range(len(sec)), key=lambda k: sec[k])
    ax.plot([ppv[i]], [sec[i]], 'r*', ms=14, label='fastest (%.2f per voxel)' % ppv[i])
    ax.axvline(2e5 / 60 ** 3, color='gray', ls=':', label='paper: 60^3 for 2e5 particles')
    ax.set_xscale('log')
    ax.set_xlabel('particles per voxel')
    ax.set_ylabel('render CPU seconds')
    ax.set_title('Guo21 Fig. 17: time vs grid resolution')
    ax.legend()
    fig.tight_layout()
    fig.savefig(png, dpi=120)


if __name__ == '__main__':
    main(sys.argv[1], sys.argv[2])
