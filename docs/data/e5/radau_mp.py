"""High-precision reference solution of E5 (Hairer-Wanner) at t=1e5.

s-stage Radau IIA (order 2s-1, L-stable), coefficients computed in mpmath,
full Newton with analytic Jacobian, mpmath arithmetic at mp.dps digits,
on a graded mesh t(u) = tau*(exp(L*u)-1), u = k/N, L = ln(1+T/tau).

usage: radau_mp.py s N [tau] [dps]
prints final y as mpf strings (30 digits) plus diagnostics.
"""
import sys, time
import mpmath as mpm
from mpmath import mp, mpf

def radau_coeffs(s):
    # nodes: roots of d^{s-1}/dx^{s-1} [ x^{s-1} (x-1)^s ]
    x = mpm.matrix  # unused
    # polynomial coefficients of x^{s-1}(x-1)^s, highest degree first
    from math import comb
    deg = 2 * s - 1
    coef = [mpf(0)] * (deg + 1)  # coef[k] = coefficient of x^k
    for j in range(s + 1):
        # (x-1)^s = sum_j comb(s,j) x^j (-1)^{s-j}
        coef[j + s - 1] += comb(s, j) * (-1) ** (s - j)
    # differentiate s-1 times
    for _ in range(s - 1):
        coef = [coef[k] * k for k in range(1, len(coef))]
    # coef now degree s polynomial; roots
    hf = list(reversed(coef))
    with mp.extraprec(4 * mp.prec):
        roots = mpm.polyroots(hf, maxsteps=500, extraprec=4 * mp.prec)
    c = sorted([mpm.re(r) for r in roots])
    c[-1] = mpf(1)  # exact
    # a_ij = int_0^{c_i} l_j(t) dt via solving Vandermonde: sum_j a_ij c_j^{k-1} = c_i^k / k
    V = mpm.matrix(s, s)
    for k in range(s):
        for j in range(s):
            V[k, j] = c[j] ** k
    A = mpm.matrix(s, s)
    for i in range(s):
        rhs = mpm.matrix([c[i] ** (k + 1) / (k + 1) for k in range(s)])
        row = mpm.lu_solve(V, rhs)
        for j in range(s):
            A[i, j] = row[j]
    return c, A

Ac = mpf('7.89e-10'); Bc = mpf('1.1e7'); Cc = mpf('1.13e3'); Mc = mpf('1e6')
CM = Cc * Mc

def f(y):
    y1, y2, y3, y4 = y
    p1 = Ac * y1; p2 = Bc * y1 * y3; p3 = CM * y2 * y3; p4 = Cc * y4
    return [-p1 - p2, p1 - p3, p1 - p2 - p3 + p4, p2 - p4]

def jac(y):
    y1, y2, y3, y4 = y
    # rows: d f_i / d y_j
    return [[-Ac - Bc * y3, 0, -Bc * y1, 0],
            [Ac, -CM * y3, -CM * y2, 0],
            [Ac - Bc * y3, -CM * y3, -Bc * y1 - CM * y2, Cc],
            [Bc * y3, 0, Bc * y1, -Cc]]

def step(y0, h, c, A, s, Zguess, tol, floor):
    n = 4
    Z = [list(z) for z in Zguess]
    for it in range(60):
        Y = [[y0[k] + Z[i][k] for k in range(n)] for i in range(s)]
        F = [f(Yi) for Yi in Y]
        J = [jac(Yi) for Yi in Y]
        # residual G = Z - h A F
        G = mpm.matrix(n * s, 1)
        M = mpm.matrix(n * s, n * s)
        for i in range(s):
            for k in range(n):
                acc = Z[i][k]
                for j in range(s):
                    acc -= h * A[i, j] * F[j][k]
                G[i * n + k] = -acc
            for j in range(s):
                hA = h * A[i, j]
                Jj = J[j]
                for k in range(n):
                    for l in range(n):
                        v = -hA * Jj[k][l]
                        if i == j and k == l:
                            v += 1
                        M[i * n + k, j * n + l] = v
        dZ = mpm.lu_solve(M, G)
        err = mpf(0)
        for i in range(s):
            for k in range(n):
                d = dZ[i * n + k]
                Z[i][k] += d
                sc = abs(y0[k]) + abs(Z[i][k]) + floor
                e = abs(d) / sc
                if e > err:
                    err = e
        if err < tol:
            return Z, it + 1
    raise RuntimeError("Newton did not converge, h=%s err=%s" % (h, err))

def lagrange_extrap(c, Z, s, theta):
    # collocation poly u(x) with u(0)=0, u(c_i)=Z_i (x in units of old h);
    # evaluate at x = 1 + theta*c_j for new stages, return Z_new relative to new y0 = y0+Z_s
    nodes = [mpf(0)] + list(c)
    vals = [[mpf(0)] * 4] + Z
    out = []
    for cj in c:
        x = 1 + theta * cj
        u = [mpf(0)] * 4
        for a in range(len(nodes)):
            w = mpf(1)
            for b in range(len(nodes)):
                if b != a:
                    w *= (x - nodes[b]) / (nodes[a] - nodes[b])
            for k in range(4):
                u[k] += w * vals[a][k]
        out.append([u[k] - Z[-1][k] for k in range(4)])
    return out

def solve(s, N, tau, dps, T=mpf(10) ** 5, verbose=False):
    mp.dps = dps
    T = mpf(T); tau = mpf(tau)
    c, A = radau_coeffs(s)
    L = mpm.log(1 + T / tau)
    y = [mpf('1.76e-3'), mpf(0), mpf(0), mpf(0)]
    tol = mpf(10) ** (-(dps - 6))
    floor = mpf(10) ** (-60)
    tprev = mpf(0)
    Z = [[mpf(0)] * 4 for _ in range(s)]
    hprev = None
    nit = 0
    maxinv = mpf(0)
    for kk in range(1, N + 1):
        t = T if kk == N else tau * mpm.expm1(L * kk / N)
        h = t - tprev
        if hprev is not None:
            Zg = lagrange_extrap(c, Z, s, h / hprev)
        else:
            Zg = [[mpf(0)] * 4 for _ in range(s)]
        Z, it = step(y, h, c, A, s, Zg, tol, floor)
        nit += it
        y = [y[k] + Z[-1][k] for k in range(4)]
        if y[1] != 0:
            inv = abs(y[1] - y[2] - y[3]) / abs(y[1])
            if inv > maxinv:
                maxinv = inv
        tprev = t; hprev = h
        if verbose and kk % max(1, N // 10) == 0:
            print(kk, mpm.nstr(t, 6), [mpm.nstr(v, 10) for v in y], flush=True)
    return y, nit, maxinv

if __name__ == '__main__':
    s = int(sys.argv[1]); N = int(sys.argv[2])
    tau = sys.argv[3] if len(sys.argv) > 3 else '1e-6'
    dps = int(sys.argv[4]) if len(sys.argv) > 4 else 32
    t0 = time.time()
    y, nit, maxinv = solve(s, N, tau, dps, verbose=('-v' in sys.argv))
    el = time.time() - t0
    print("RESULT s=%d N=%d tau=%s dps=%d newton_its=%d time=%.1f maxinv=%s" % (
        s, N, tau, dps, nit, el, mpm.nstr(maxinv, 3)))
    for v in y:
        print(mpm.nstr(v, 30))
    print("inv_final", mpm.nstr((y[1] - y[2] - y[3]) / y[1], 5))
