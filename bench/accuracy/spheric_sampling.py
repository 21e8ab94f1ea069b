#!/usr/bin/env python3
"""SPHERIC test 2: P1 (and the probes beside it) read at every step, sampled as the run's recorder would
(output.probe_sampling: instant and mean over 1 ms, backend/store/ProbeSeries.h's rule: every step's reading joined
by straight lines, integrated over the window, divided by it) and box-filtered 1-5 ms wide, against the experiment.
Prints the table of docs/sph.md ("Not the sampling") and the ringing's strongest frequencies; with a third
argument, charts P1 read every step, as 1 ms means and box-filtered 5 ms wide against the experiment into that PNG.

    python3 bench/accuracy/spheric_sampling.py docs/sph/spheric2_dp0.0064_steps.probes.csv \
        bench/accuracy/data/kleefsman_2005_spheric_test2_0-1s.csv [docs/sph/spheric2_p1_sampling.png]
"""
import sys

import numpy as np

from plot_spheric import table  # the probes' and the record's CSV, columns by name


def read(path):
    """A CSV as plot_spheric.table reads it: its columns' names and the rows as an array."""
    columns = table(path)
    names = list(columns)
    return names, np.array([columns[n] for n in names]).T


def samples(t, v, interval, mean):
    """The recorder's samples after t[0]: at the first step at or past each multiple of `interval`."""
    out_t, out_v = [], []
    nxt = (np.floor(t[0] / interval + 1e-9) + 1) * interval
    acc, start = 0.0, t[0]
    for i in range(1, len(t)):
        acc += 0.5 * (v[i] + v[i - 1]) * (t[i] - t[i - 1])
        if t[i] >= nxt * (1 - 1e-12):
            out_t.append(t[i])
            out_v.append(acc / (t[i] - start) if mean else v[i])
            acc, start = 0.0, t[i]
            while nxt <= t[i] * (1 + 1e-12):
                nxt += interval
    return np.array(out_t), np.array(out_v)


def first_above(t, v, level=500.0):
    return t[np.argmax(v > level)] if (v > level).any() else float('nan')


def main():
    names, run = read(sys.argv[1])
    enames, exp = read(sys.argv[2])
    t = run[:, 0]
    window = (0.38, 0.462)
    te, pe = exp[:, 0], exp[:, enames.index('P1')]
    w = (te > window[0]) & (te < window[1])
    late = (te > 0.42) & (te < window[1])
    print('%-22s %-9s %-18s %s' % ('P1 read', 'first>500', 'peak [kPa] (at s)', 'mean 0.42-0.462 s [kPa] (range)'))
    print('%-22s %-9.4f %-18s %.1f' % ('experiment', first_above(te[w], pe[w]), '%.1f (%.4f)' % (pe[w].max() / 1e3, te[w][pe[w].argmax()]),
                                        pe[late].mean() / 1e3))
    for probe in [n for n in ('P1', 'P1h2', 'P1h', 'P2') if n in names]:
        v = run[:, names.index(probe)]
        rows = [('every step', t, v)]
        rows.append(('instant each ms', *samples(t, v, 1e-3, False)))
        rows.append(('mean over each ms', *samples(t, v, 1e-3, True)))
        tu = np.arange(t[0], t[-1], 2e-5)
        vu = np.interp(tu, t, v)
        for width in (2e-3, 3e-3, 5e-3):
            n = int(round(width / 2e-5))
            rows.append(('box %.0f ms' % (width * 1e3), tu, np.convolve(vu, np.ones(n) / n, 'same')))
        for label, tt, vv in rows:
            m = (tt > window[0]) & (tt < window[1])
            l = (tt > 0.42) & (tt < window[1])
            print('%-22s %-9.4f %-18s %.1f (%.0f to %.0f)' % (probe + ' ' + label, first_above(tt[m], vv[m]),
                  '%.1f (%.4f)' % (vv[m].max() / 1e3, tt[m][vv[m].argmax()]), vv[l].mean() / 1e3, vv[l].min() / 1e3, vv[l].max() / 1e3))
        x = vu[(tu > 0.42) & (tu < 0.46)]
        f = np.fft.rfftfreq(len(x), 2e-5)
        a = np.abs(np.fft.rfft(x - x.mean()))
        band = f > 100
        top = np.argsort(a[band])[::-1][:4]
        print('%s ringing above 100 Hz, strongest: %s Hz' % (probe, ', '.join('%.0f' % q for q in f[band][top])))


def chart(run_path, exp_path, png):
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    names, run = read(run_path)
    enames, exp = read(exp_path)
    t, v = run[:, 0], run[:, names.index('P1')]
    tm, vm = samples(t, v, 1e-3, True)
    tu = np.arange(t[0], t[-1], 2e-5)
    vu = np.interp(tu, t, v)
    n = int(round(5e-3 / 2e-5))
    box = np.convolve(vu, np.ones(n) / n, 'same')
    fig, ax = plt.subplots(figsize=(8, 4.2))
    ax.plot(t, v / 1e3, color='0.75', lw=0.8, label='run, every step (55 µs)')
    ax.plot(tm, vm / 1e3, color='tab:blue', lw=1.2, drawstyle='steps-pre', label='run, mean over each 1 ms (probe_sampling: mean)')
    ax.plot(tu, box / 1e3, color='tab:green', lw=1.2, label='run, box filter 5 ms')
    ax.plot(exp[:, 0], exp[:, enames.index('P1')] / 1e3, color='k', lw=1.5, label='experiment (Kleefsman et al. 2005), ≈1 kHz')
    ax.set_xlim(0.385, 0.47)
    ax.set_xlabel('t [s]')
    ax.set_ylabel('P1 [kPa]')
    ax.set_title('SPHERIC test 2, P1: dp 6.4 mm, float, velocity Verlet (H200)')
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc='upper right')
    fig.tight_layout()
    fig.savefig(png, dpi=110)


if __name__ == '__main__':
    main()
    if len(sys.argv) > 3:
        chart(sys.argv[1], sys.argv[2], sys.argv[3])
