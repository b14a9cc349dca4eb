#!/usr/bin/env python3
"""Reference OKID -> ERA/DC -> MKR in numpy, for the speed comparison of the README.

Usage: python3 benches/numpy_reference.py [--order P] [--repeat N] hit01.csv hit02.csv ...

Reads the hit CSVs written by `frameid simulate` (time, force, acc1..accN), fits the
observer (ARX) model with 8 input leads by one least-squares solve of the stacked
regression (numpy.linalg.lstsq, like the QR route of frameid), recovers the system Markov
parameters, realizes them by ERA/DC with frameid's default Hankel size, converts the poles
to continuous time (impulse invariance, band-limited records) and builds M, K and the
damping matrix from the residues (MKR). No error bars: this is the workload of
`frameid identify --no-uncertainty` at a fixed observer order. Prints M, K and the wall
time per identification (reading the files included).
"""
import sys
import time

import numpy as np


def read(path):
    data = np.loadtxt(path, delimiter=",", skiprows=1)
    dt = data[1, 0] - data[0, 0]
    return dt, data[:, 1:2].T, data[:, 2:].T  # u: r x N, y: m x N


def regression(u, y, p, q):
    r, n = u.shape
    m = y.shape[0]
    rows = n - q
    up = np.zeros((r, n + p))
    yp = np.zeros((m, n + p))
    up[:, p:] = u
    yp[:, p:] = y
    cols = []
    for t in range(q, 0, -1):  # leads u[n + t]
        cols.append(u[:, t : t + rows])
    cols.append(u[:, :rows])
    for i in range(1, p + 1):
        cols.append(up[:, p - i : p - i + rows])
        cols.append(yp[:, p - i : p - i + rows])
    return np.vstack(cols).T, y[:, :rows].T


def okid(records, p, q, count, rcond):
    xs, ys = zip(*(regression(u, y, p, q) for u, y in records))
    x, yt = np.vstack(xs), np.vstack(ys)
    scale = np.sqrt((x**2).mean(axis=0))
    scale[scale == 0] = 1.0
    theta = np.linalg.lstsq(x / scale, yt, rcond=rcond)[0] / scale[:, None]
    r, m = records[0][0].shape[0], records[0][1].shape[0]
    theta = theta.T  # m x columns
    a = [theta[:, t * r : (t + 1) * r] for t in range(q + 1)]  # a_{-q} .. a_0
    b = []
    for i in range(1, p + 1):
        base = (q + 1) * r + (i - 1) * (r + m)
        a.append(theta[:, base : base + r])
        b.append(theta[:, base + r : base + r + m])
    g = []
    for idx in range(q + count):
        acc = a[idx].copy() if idx < len(a) else np.zeros((m, r))
        for i, bi in enumerate(b):
            if idx >= i + 1:
                acc += bi @ g[idx - i - 1]
        g.append(acc)
    return g[q:]


def era_dc(markov, order, offset, alpha, beta, xi=2, zeta=2):
    m, r = markov[0].shape

    def hankel(k):
        return np.block(
            [[markov[offset + 1 + k + i + j] for j in range(beta)] for i in range(alpha)]
        )

    h0 = hankel(0)
    corr = [hankel(k) @ h0.T for k in range(xi + zeta + 2)]

    def block(k):
        return np.block([[corr[k + i + j] for j in range(zeta + 1)] for i in range(xi + 1)])

    u, s, vt = np.linalg.svd(block(0))
    un, vn, sq = u[:, :order], vt[:order].T, np.sqrt(s[:order])
    a = (un.T @ block(1) @ vn) / np.outer(sq, sq)
    obs = (un * sq)[: alpha * m]
    ctrl = np.linalg.lstsq(obs, h0, rcond=1e-13)[0]
    bmat = ctrl[:, :r]
    for _ in range(offset):
        bmat = np.linalg.solve(a, bmat)
    return a, bmat, obs[:m], markov[0]


def mkr(a, b, c, d, dt, k=0, l=0):
    mu, v = np.linalg.eig(a)
    lam = np.log(mu.astype(complex)) / dt
    keep = np.argsort(np.abs(lam))
    left = np.linalg.inv(v)
    modes = [j for j in keep if lam[j].imag > 0][: c.shape[0]]
    w = []
    poles = []
    for j in modes:
        res = np.outer(c @ v[:, j], left[j] @ b) / (dt * mu[j])
        wk = np.sqrt(res[k, l] / lam[j] ** 2)
        col = res[:, l] / (lam[j] ** 2 * wk)
        col[k] = wk
        w += [col, col.conj()]
        poles += [lam[j], lam[j].conj()]
    w, poles = np.array(w).T, np.array(poles)
    prod = lambda power: ((w * poles**power) @ w.T).real
    mass = np.linalg.inv(prod(1))
    stiffness = -np.linalg.inv(prod(-1))
    damping = -mass @ prod(2) @ mass
    return mass, stiffness, damping


def identify(paths, p):
    loaded = [read(f) for f in paths]
    dt = loaded[0][0]
    records = [(u, y) for _, u, y in loaded]
    m = records[0][1].shape[0]
    q, offset = 8, 10
    alpha = -(-max(4 * 20, 40) // m)
    beta = min(3 * alpha * m, records[0][0].shape[1] - offset - alpha - 5)
    markov = okid(records, p, q, offset + alpha + beta + 5 + 1, 1e-4)
    a, b, c, d = era_dc(markov, 2 * m, offset, alpha, beta)
    return mkr(a, b, c, d, dt)


def main(argv):
    p, repeat, files = 10, 5, []
    it = iter(argv)
    for arg in it:
        if arg == "--order":
            p = int(next(it))
        elif arg == "--repeat":
            repeat = int(next(it))
        else:
            files.append(arg)
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        mass, stiffness, damping = identify(files, p)
        times.append(time.perf_counter() - t0)
    np.set_printoptions(precision=5)
    print("M =", mass, "\nK =", stiffness, "\ndamping =", damping, sep="\n")
    print(f"identification: best {min(times) * 1e3:.1f} ms, median {np.median(times) * 1e3:.1f} ms of {repeat}")


if __name__ == "__main__":
    main(sys.argv[1:])
