"""Plot of examples/moon07_fig2_retroreflection (Moon07 Fig. 2): far-field distribution of the
rays scattered by small sparse and large closely packed dielectric circles (2D) and spheres (3D),
each against the volumetric (continuous medium) prediction with the same mean free path.
Usage: moon07_fig2.py CSV PNG (Debian's /usr/bin/python3 with matplotlib)."""
import csv
import sys

import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402


def main(csv_path, png):
    with open(csv_path) as f:
        rows = list(csv.reader(f))
    d = {k: [float(r[i]) for r in rows[1:]] for i, k in enumerate(rows[0])}
    th = d['theta_deg']
    fig, ax = plt.subplots(2, 2, figsize=(12, 8))
    for i, dim in enumerate(['2d', '3d']):
        for j, case in enumerate(['sparse', 'packed']):
            a = ax[i][j]
            key = '%s_%s' % (dim, case)
            a.semilogy(th, d[key + '_explicit'], '-', lw=1.2, label='explicit %s' % case)
            a.semilogy(th, d[key + '_volumetric'], '--', lw=1.2, label='volumetric (same mean free path)')
            lo = [max(1e-12, v - s) for v, s in zip(d[key + '_explicit'], d[key + '_explicit_se'])]
            hi = [v + s for v, s in zip(d[key + '_explicit'], d[key + '_explicit_se'])]
            a.fill_between(th, lo, hi, alpha=0.3)
            a.set_xlim(0, 180)
            a.set_title('%s, %s %s' % (dim.upper(), 'small well-separated' if case == 'sparse' else 'large closely packed',
                                       'circles' if dim == '2d' else 'spheres'))
            a.set_xlabel('angle from the incident direction [deg]')
            a.set_ylabel('scattered rays per incident ray per %s' % ('radian' if dim == '2d' else 'sr'))
            a.legend(fontsize=8)
    fig.suptitle('Moon07 Fig. 2: far field of dielectric scatterers (eta = 1.5) vs the volumetric prediction')
    fig.tight_layout()
    fig.savefig(png, dpi=110)


if __name__ == '__main__':
    main(sys.argv[1], sys.argv[2])
