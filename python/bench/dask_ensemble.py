"""An encoder-robot ensemble on a 2-worker Dask LocalCluster against one process.

The README's ensemble (20 000 members × 4 000 encoder samples, pulse noise, slip and
between-member spreads) run five ways, interleaved, best of `repeats` wall times:

- one process, one thread: `EncoderEnsemble.run(threads=1)`;
- one process, every core: `EncoderEnsemble.run()` (rayon, the GIL released);
- Dask: `reckon.dask.encoder_ensemble` on `LocalCluster(n_workers=2,
  threads_per_worker=1, processes=True)`, two shards and eight shards (the cluster
  started once, before the clock; a warm-up run first, so the workers have imported
  reckon);
- with `--cli PATH`, the Rust CLI `reckon ensemble --threads 1` and with every core on
  the same members (its `--stats` must have the same snapshots bit for bit).

Prints each best wall time with the CPU time it took (this process, the CLI child and
the Dask workers), the speed-ups against one thread, and checks that every result holds
the same bits.

    python bench/dask_ensemble.py [members] [repeats] [--cli target/release/reckon]
"""

import json
import os
import resource
import subprocess
import sys
import tempfile
import time

import distributed

import reckon
import reckon.dask

COMMANDS = [(1.0, 0.0, 10.0), (0.5, 0.3, 10.0), (1.0, 0.0, 10.0), (0.5, -0.3, 10.0)]
DT = 0.01  # 4 000 samples per member
MODEL = dict(wheel_diameter=0.1, wheel_separation=0.5, pulses_per_rev=1000, pulse_noise=2.0,
             slip=0.002, diameter_sigma=1e-3, wheelbase_sigma=1e-3)
SEED = 42


def snapshots(text):
    d = json.loads(text)
    return d["layout"]["names"], d["members"], d["seed"], d["snapshots"]


def cpu_seconds(client=None):
    """CPU time of this process, its finished children (the CLI) and the Dask workers."""
    own = time.process_time() + resource.getrusage(resource.RUSAGE_CHILDREN).ru_utime
    own += resource.getrusage(resource.RUSAGE_CHILDREN).ru_stime
    if client is not None:
        own += sum(client.run(time.process_time).values())
    return own


def timed(f, client=None):
    c, w = cpu_seconds(client), time.perf_counter()
    r = f()
    w = time.perf_counter() - w
    return w, cpu_seconds(client) - c, r


def main():
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    cli = sys.argv[sys.argv.index("--cli") + 1] if "--cli" in sys.argv else None
    if cli:
        args.remove(cli)
    members = int(args[0]) if args else 20_000
    repeats = int(args[1]) if len(args) > 1 else 3
    drive = reckon.EncoderEnsemble(COMMANDS, DT, **MODEL)
    print(f"{members} members × {drive.samples_per_member:.0f} samples, {os.cpu_count()} cores, "
          f"load {os.getloadavg()[0]:.1f}")
    best = {}
    results = {}

    def keep(name, t, cpu, text):
        if t < best.get(name, (float("inf"),))[0]:
            best[name] = (t, cpu)
        results.setdefault(name, text)

    csv = stats = None
    if cli:
        tmp = tempfile.mkdtemp()
        csv, stats = os.path.join(tmp, "controls.csv"), os.path.join(tmp, "stats.json")
        t = 0.0
        with open(csv, "w") as f:
            f.write("t,v,omega\n")
            for v, w, d in COMMANDS:
                f.write(f"{t!r},{v!r},{w!r}\n")
                t += d
            f.write(f"{t!r},0,0\n")

    def run_cli(threads):
        cmd = [cli, "ensemble", "--model", "unicycle", "--controls", csv, "--members", str(members),
               "--seed", str(SEED), "--wheel-diameter", "0.1", "--wheel-separation", "0.5",
               "--pulses-per-rev", "1000", "--pulse-noise", "2", "--slip", "0.002",
               "--diameter-sigma", "0.001", "--wheelbase-sigma", "0.001", "--dt", str(DT),
               "--save-every", "1", "--stats", stats, "--out", os.devnull]
        if threads:
            cmd += ["--threads", str(threads)]
        subprocess.run(cmd, check=True)
        with open(stats) as f:
            return f.read()

    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        reckon.dask.encoder_ensemble(client, drive, 200, SEED)  # warm-up: imports on the workers
        for _ in range(repeats):
            keep("1 process, 1 thread", *timed(lambda: drive.run(members, SEED, threads=1).to_json()))
            keep("1 process, 2 threads", *timed(lambda: drive.run(members, SEED).to_json()))
            keep("Dask, 2 workers × 1 thread", *timed(
                lambda: reckon.dask.encoder_ensemble(client, drive, members, SEED).to_json(), client))
            keep("Dask, 8 shards on 2 workers", *timed(
                lambda: reckon.dask.encoder_ensemble(client, drive, members, SEED, shards=8).to_json(),
                client))
            if cli:
                keep("CLI, 1 thread", *timed(lambda: run_cli(1)))
                keep("CLI, 2 threads", *timed(lambda: run_cli(None)))
    reference = snapshots(results["1 process, 1 thread"])
    for name, text in results.items():
        assert snapshots(text) == reference, f"{name}: not the same bits"
    one = best["1 process, 1 thread"][0]
    for name, (t, cpu) in best.items():
        print(f"{name:28s} {t:7.3f} s wall  {cpu:7.3f} s CPU  speed-up {one / t:4.2f}×  "
              f"{members * drive.samples_per_member / t / 1e6:6.1f} M samples/s")
    print("every result: the same statistics, bit for bit")


if __name__ == "__main__":
    main()
