"""Two Python threads solving traced models at once: the GIL is released while a traced
model integrates, so on two free cores the pair takes about the time of one.

Solves the 1-D Brusselator (N grid points, 2N states) with BDF, first twice in a row
on one thread, then once on each of two threads started together, and prints the wall
times, the process CPU time and the speed-up (sequential wall / parallel wall; 2.0 is
perfect, 1.0 means the threads ran one after the other).

    python bench/threads.py [N] [repeats]
"""

import sys
import threading
import time

import numpy as np

import reckon
from traced import brusselator  # bench/traced.py, beside this script


def main():
    N = int(sys.argv[1]) if len(sys.argv) > 1 else 500
    repeats = int(sys.argv[2]) if len(sys.argv) > 2 else 3
    f, y0 = brusselator(N)
    model = reckon.Model(f, 2 * N)

    def solve():
        r = reckon.solve_ivp(model, (0, 10), y0, method="BDF", rtol=1e-8, atol=1e-10, t_eval=[10.0])
        assert r.success

    solve()  # warm-up
    best_seq, best_par, cpu_par = np.inf, np.inf, np.inf
    for _ in range(repeats):
        w, c = time.perf_counter(), time.process_time()
        solve()
        solve()
        best_seq = min(best_seq, time.perf_counter() - w)
        threads = [threading.Thread(target=solve) for _ in range(2)]
        w, c = time.perf_counter(), time.process_time()
        for th in threads:
            th.start()
        for th in threads:
            th.join()
        wall = time.perf_counter() - w
        if wall < best_par:
            best_par, cpu_par = wall, time.process_time() - c
    print(f"Brusselator 1-D, {2 * N} states, BDF rtol 1e-8; best of {repeats}")
    print(f"  two solves on one thread:   {best_seq * 1e3:8.1f} ms wall")
    print(f"  one solve on each of two:   {best_par * 1e3:8.1f} ms wall, {cpu_par * 1e3:8.1f} ms CPU")
    print(f"  speed-up {best_seq / best_par:.2f} (2.0 = both cores busy throughout)")


if __name__ == "__main__":
    main()
