"""Plots of examples/meng15_fig9_fluence (Meng15 Fig. 9 / Fig. 10): exit density on the detector
spheres against the inclination, EPT vs VPT with the derived parameters (PNG), and the projected
exit directions for theta < 45 degrees (PNG with _radiance before .png).
Usage: meng15_fig9_fluence.py FLUENCE_CSV PNG RADIANCE_CSV N_FIELD (Debian's /usr/bin/python3
with matplotlib and numpy)."""
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


def same_radius(value, r):
    return str(value).rstrip('0').rstrip('.') == r.rstrip('0').rstrip('.')


def main(fluence_csv, png, radiance_csv, n_field):
    d = read_csv(fluence_csv)
    fig, axs = plt.subplots(1, 2, figsize=(10, 4))
    for ax, g, lab in ((axs[0], 'glass-bead', 'dielectric spheres'), (axs[1], 'snow', 'snow')):
        for r, c in (('7.5', 'C0'), ('15', 'C3')):
            sel = [i for i in range(len(d['grain'])) if d['grain'][i] == g and same_radius(d['radius_mfp'][i], r)]
            th = [d['theta_deg'][i] for i in sel]
            ax.semilogy(th, [d['fluence_ept'][i] for i in sel], 'o', color=c, label='EPT %s mfp' % r)
            ax.semilogy(th, [d['fluence_vpt'][i] for i in sel], '-', color=c, label='VPT %s mfp' % r)
        ax.set_xlabel('inclination theta [deg]')
        ax.set_ylabel('exit density per source photon [1/R^2]')
        ax.set_title(lab)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(png, dpi=110)

    r = read_csv(radiance_csv)
    n = int(n_field)
    fig, axs = plt.subplots(2, 4, figsize=(12, 6))
    for row, g in enumerate(('glass-bead', 'snow')):
        for col, (rad, m) in enumerate((('7.5', 'ept'), ('7.5', 'vpt'), ('15', 'ept'), ('15', 'vpt'))):
            img = np.zeros((n, n))
            for i in range(len(r['grain'])):
                if (r['grain'][i] == g and same_radius(r['radius_mfp'][i], rad) and r['method'][i] == m
                        and int(r['band'][i]) == 0):
                    img[int(r['iy'][i]), int(r['ix'][i])] = r['value'][i]
            axs[row][col].imshow(img, origin='lower', extent=(-1, 1, -1, 1), cmap='inferno')
            axs[row][col].set_title('%s %s mfp %s (theta<45)' % (g, rad, m.upper()), fontsize=9)
    fig.tight_layout()
    fig.savefig(png.replace('.png', '_radiance.png'), dpi=100)


if __name__ == '__main__':
    main(sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4])
