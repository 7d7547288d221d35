"""Plot of examples/moon07_shell_transport (Moon07 shell transport of glass spheres): Fig. 8's
exit-position marginal per shell radius and the attenuation f_a, the NMF reconstruction error vs
rank, and shell stepping against explicit path tracing (mean-square displacement, mean direction
cosine, radial distribution after the last step).
Usage: moon07_shell_transport.py FIG8_CSV PNG FA_CSV STEPS_CSV RADIAL_CSV NMF_CSV
(Debian's /usr/bin/python3 with matplotlib and numpy)."""
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


def main(fig8_csv, png, fa_csv, steps_csv, radial_csv, nmf_csv):
    f8, fa, st, ra, nm = (read_csv(p) for p in (fig8_csv, fa_csv, steps_csv, radial_csv, nmf_csv))
    fig, ax = plt.subplots(2, 3, figsize=(14, 8))
    th = np.degrees(np.arccos(f8['cos_theta1']))
    for k in ['p_r2', 'p_r4', 'p_r6', 'p_r8', 'p_r10', 'p_r12']:
        ax[0, 0].semilogy(th, f8[k], label='r = ' + k[3:] + ' R')
    ax[0, 0].set_xlabel('theta_1 (deg)')
    ax[0, 0].set_ylabel('p_r(cos theta_1), scattered exits')
    ax[0, 0].legend(fontsize=7)
    ax[0, 0].set_title('Fig. 8 top: exit position marginal')
    ax[0, 1].semilogy(fa['d_over_R'], fa['f_a'], 'k-', label='f_a(d) measured')
    ax[0, 1].semilogy(fa['d_over_R'], fa['exp_same_mean'], 'r--', label='exponential, same mean')
    ax[0, 1].set_xlabel('d / R')
    ax[0, 1].legend()
    ax[0, 1].set_title('Fig. 8 bottom: attenuation f_a')
    ax[0, 2].semilogy(nm['rank'], nm['relative_error'], 'o-')
    ax[0, 2].set_xlabel('NMF rank')
    ax[0, 2].set_ylabel('||V - WH|| / ||V||')
    ax[0, 2].set_title('NMF reconstruction error')
    ax[1, 0].errorbar(st['step'], st['msd_explicit'], yerr=np.array(st['msd_explicit_se']) * 2, fmt='ko',
                      label='explicit spheres')
    ax[1, 0].plot(st['step'], st['msd_shells'], 'r-', label='shell stepping')
    ax[1, 0].set_xlabel('steps (r = 8 R)')
    ax[1, 0].set_ylabel('<|x|^2> / R^2')
    ax[1, 0].legend()
    ax[1, 1].plot(st['step'], st['cos_explicit'], 'ko', label='explicit')
    ax[1, 1].plot(st['step'], st['cos_shells'], 'r-', label='shells')
    ax[1, 1].set_xlabel('steps')
    ax[1, 1].set_ylabel('<omega_n . omega_0>')
    ax[1, 1].legend()
    ax[1, 2].plot(ra['radius_over_R'], ra['pdf_explicit'], 'k.', label='explicit')
    ax[1, 2].plot(ra['radius_over_R'], ra['pdf_shells'], 'r-', label='shells')
    ax[1, 2].set_xlabel('|x_n| / R after the last step')
    ax[1, 2].set_ylabel('pdf')
    ax[1, 2].legend()
    fig.tight_layout()
    fig.savefig(png, dpi=100)


if __name__ == '__main__':
    main(*sys.argv[1:7])
