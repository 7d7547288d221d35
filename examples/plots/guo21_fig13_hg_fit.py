"""Plot of examples/guo21_fig13_hg_fit (Guo21 Fig. 13, right): our tabulated phase function of
1000 um ice spheres (GOA with Fraunhofer diffraction) against the best-fit Henyey-Greenstein phases
(same g; least squares in ln p). Usage: guo21_fig13_hg_fit.py PHASE_CSV PNG (Debian's
/usr/bin/python3 with matplotlib)."""
import csv
import sys

import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402


def main(csv_path, png):
    with open(csv_path) as f:
        rows = list(csv.DictReader(f))
    theta = [float(r['theta_deg']) for r in rows]
    fig, ax = plt.subplots(1, 2, figsize=(11, 4))
    for a, xlog in zip(ax, (False, True)):
        t = [max(x, 1e-3) for x in theta] if xlog else theta
        a.plot(t, [float(r['phase_tabulated']) for r in rows], 'r-', label='ours (tabulated)')
        a.plot(t, [float(r['phase_hg_same_g']) for r in rows], 'b--', label='HG, same g')
        a.plot(t, [float(r['phase_hg_lsq']) for r in rows], 'g:', label='HG, least squares ln p')
        a.set_yscale('log')
        if xlog:
            a.set_xscale('log')
        a.set_xlabel('scattering angle [deg]')
        a.set_ylabel('phase function [1/sr]')
        a.legend()
    fig.suptitle('Guo21 Fig. 13: tabulated phase of 1000 um ice spheres vs best-fit HG')
    fig.tight_layout()
    fig.savefig(png, dpi=120)


if __name__ == '__main__':
    main(sys.argv[1], sys.argv[2])
