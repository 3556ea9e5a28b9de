"""GTSAM's cost per IMU sample, for the comparison with `cargo bench --bench preintegration`.

The same samples as reckon's bench (the four sequences of
tests/golden/lie/gtsam_preintegration.json, 1 900 samples), integrated by GTSAM's
`PreintegratedImuMeasurementsManifold` (Forster et al. 2017, the scheme reckon
implements) and, for reference, the PyPI build's default tangent-space
`PreintegratedImuMeasurements`. GTSAM has no batch call in Python, so each sample is one
`integrateMeasurement(acc, gyro, dt)` call; the cost of the call itself (the Python loop,
pybind11's dispatch and the two numpy → Eigen conversions) is measured with a call that
converts the same arguments and does nothing else: `imuBias.ConstantBias(acc, gyro)`
(which also allocates its result, so the overhead is if anything overestimated and
GTSAM's C++ time underestimated). Reported: per sample, best of `repeats` rounds,
interleaved, in process CPU time (`time.process_time`), with the spread over rounds.

    /tmp/gtsam-venv/bin/python docs/lie/gtsam_preintegration_cost.py [repeats]
"""

import json
import sys
import time
from importlib.metadata import version
from pathlib import Path

import gtsam
import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from gtsam_preintegration import make_params  # noqa: E402  (the reference values' parameters)


def main():
    repeats = int(sys.argv[1]) if len(sys.argv) > 1 else 15
    doc = json.load(open("tests/golden/lie/gtsam_preintegration.json"))
    cases = []
    for c in doc["cases"]:
        gz = c["gravity"][2]  # (0, 0, -g) with z up, (0, 0, g) with NED
        params = make_params(gz < 0, abs(gz), c["gyro_sigma"], c["accel_sigma"], c["integration_sigma"])
        assert np.allclose(params.n_gravity, c["gravity"], rtol=0, atol=1e-15)
        bias = gtsam.imuBias.ConstantBias(np.array(c["bias_hat"]["accel"]), np.array(c["bias_hat"]["gyro"]))
        samples = [(np.array(s["accel"], dtype=float), np.array(s["gyro"], dtype=float), float(s["dt"]))
                   for s in c["samples"]]
        cases.append((params, bias, samples))
    n = sum(len(s) for _, _, s in cases)

    def integrate(cls):
        t = time.process_time()
        for params, bias, samples in cases:
            pim = cls(params, bias)
            for a, w, dt in samples:
                pim.integrateMeasurement(a, w, dt)
        return time.process_time() - t

    def overhead():
        t = time.process_time()
        for params, bias, samples in cases:
            make = gtsam.imuBias.ConstantBias
            for a, w, dt in samples:
                make(a, w)
        return time.process_time() - t

    rounds = {"manifold": [], "tangent": [], "overhead": []}
    for _ in range(repeats):  # interleaved
        rounds["manifold"].append(integrate(gtsam.PreintegratedImuMeasurementsManifold))
        rounds["tangent"].append(integrate(gtsam.PreintegratedImuMeasurements))
        rounds["overhead"].append(overhead())
    ns = {k: np.array(v) / n * 1e9 for k, v in rounds.items()}
    print(f"gtsam {version('gtsam')}, numpy {np.__version__}, {n} samples, best of {repeats} "
          f"(median in brackets), process CPU time per sample:")
    for k, v in ns.items():
        print(f"  {k:9} {v.min():8.1f} ns  [{np.median(v):8.1f}]")
    for k in ("manifold", "tangent"):
        print(f"  {k} minus call overhead: {ns[k].min() - ns['overhead'].min():.1f} ns per sample (C++ estimate)")


if __name__ == "__main__":
    main()
