"""Plot of examples/guo21_fig5_mie_vs_goa (Guo21 Fig. 5): the normalized phase functions of
monodisperse particles (eta = 1.33) by Lorenz-Mie and by GOA, one panel per radius.
Usage: guo21_fig5_mie_vs_goa.py PHASE_CSV PNG (Debian's /usr/bin/python3 with matplotlib)."""
import csv
import sys

import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402


def main(csv_path, png):
    with open(csv_path) as f:
        rows = list(csv.DictReader(f))
    theta = [float(r['theta_deg']) for r in rows]
    radii = [k[len('phase_mie_'):] for k in rows[0] if k.startswith('phase_mie_')]
    fig, ax = plt.subplots(1, len(radii), figsize=(5.5 * len(radii), 4), squeeze=False)
    for a, r in zip(ax[0], radii):
        a.semilogy(theta, [float(x['phase_mie_' + r]) for x in rows], 'r-', label='Lorenz-Mie')
        a.semilogy(theta, [float(x['phase_goa_' + r]) for x in rows], 'b--', label='GOA')
        a.set_title(r.replace('r', 'r = ') + ' um')
        a.set_xlabel('scattering angle [deg]')
        a.set_ylabel('phase function [1/sr]')
        a.legend()
    fig.suptitle('Guo21 Fig. 5: Mie vs GOA phase functions (eta = 1.33)')
    fig.tight_layout()
    fig.savefig(png, dpi=120)


if __name__ == '__main__':
    main(sys.argv[1], sys.argv[2])
