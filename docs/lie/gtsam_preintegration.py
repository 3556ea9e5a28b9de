"""Reference values for reckon's IMU preintegration, computed with GTSAM.

Writes tests/golden/lie/gtsam_preintegration.json: for a few random IMU sequences (fixed
seed), GTSAM's preintegrated increments (ΔR, Δp, Δv), its 9×9 covariance preintMeasCov
(GTSAM's order and frame: [δθ, δp_body, δv_body]), the bias Jacobians and a prediction.

The class used is `PreintegratedImuMeasurementsManifold`: GTSAM's implementation of
Forster et al. 2017 (ΔR ← ΔR·Exp(ω̂ dt)). The PyPI build's default
`PreintegratedImuMeasurements` is the tangent-space variant (GTSAM_TANGENT_PREINTEGRATION:
θ ← θ + Jr⁻¹(θ)·ω̂ dt, a different discretisation); its increments are recorded too, only
to show the size of that difference.

GTSAM does not expose the bias Jacobians of the manifold class to Python; they are read
off its `predict`, which applies them (Forster eq. 44): Δp and Δv are linear in the bias
increment, so one difference with a unit step recovers each column exactly (to rounding),
and ΔR(b̂ + δb) = ΔR·Exp(∂ΔR/∂bg·δbg), so Log(ΔRᵀ·ΔR(b̂ + h·e_k))/h is column k exactly.

Run (from the repository root):
    python3 -m venv /tmp/gtsam-venv && /tmp/gtsam-venv/bin/pip install gtsam numpy
    /tmp/gtsam-venv/bin/python docs/lie/gtsam_preintegration.py
"""

import json
import sys
from importlib.metadata import version

import gtsam
import numpy as np

SEED = 20261207
OUT = "tests/golden/lie/gtsam_preintegration.json"


def mat(m):
    return [list(map(float, row)) for row in np.asarray(m)]


def vec(v):
    return list(map(float, np.asarray(v).ravel()))


def make_params(gravity_up, g, sg, sa, si):
    p = (gtsam.PreintegrationParams.MakeSharedU(g) if gravity_up
         else gtsam.PreintegrationParams.MakeSharedD(g))
    p.setGyroscopeCovariance(np.diag(np.square(sg)))
    p.setAccelerometerCovariance(np.diag(np.square(sa)))
    p.setIntegrationCovariance(np.diag(np.square(si)))
    return p


def integrate(cls, params, bias_hat, samples):
    pim = cls(params, bias_hat)
    for dt, w, a in samples:
        pim.integrateMeasurement(np.array(a), np.array(w), dt)
    return pim


def bias_jacobians(pim, bias_hat):
    """Columns of ∂Δ/∂b read off predict (see the module doc)."""
    state = gtsam.NavState()  # identity attitude, zero position and velocity
    base = pim.predict(state, bias_hat)
    dt = pim.deltaTij()
    j = {k: np.zeros((3, 3)) for k in ["dR_dbg", "dp_dba", "dp_dbg", "dv_dba", "dv_dbg"]}
    for which in ["acc", "gyro"]:
        for k in range(3):
            ba = np.array(bias_hat.accelerometer(), dtype=float)
            bg = np.array(bias_hat.gyroscope(), dtype=float)
            h = 1.0 if which == "acc" else 1e-2
            (ba if which == "acc" else bg)[k] += h
            s = pim.predict(state, gtsam.imuBias.ConstantBias(ba, bg))
            dp = (np.asarray(s.position()) - np.asarray(base.position())) / h
            dv = (np.asarray(s.velocity()) - np.asarray(base.velocity())) / h
            if which == "acc":
                j["dp_dba"][:, k], j["dv_dba"][:, k] = dp, dv
            else:
                j["dp_dbg"][:, k], j["dv_dbg"][:, k] = dp, dv
                dr = gtsam.Rot3.Logmap(base.attitude().between(s.attitude()))
                j["dR_dbg"][:, k] = np.asarray(dr) / h
    del dt
    return {k: mat(v) for k, v in j.items()}


def case(rng, name, n, dt_range, gyro_scale, accel_scale, gravity_up, spin=None):
    g = 9.81
    dts = rng.uniform(*dt_range, n)
    gyro = rng.normal(0.0, gyro_scale, (n, 3))
    if spin is not None:
        gyro += np.asarray(spin)
    accel = rng.normal(0.0, accel_scale, (n, 3)) + np.array([0.0, 0.0, g if gravity_up else -g])
    sg = rng.uniform(1e-4, 1e-2, 3)
    sa = rng.uniform(1e-3, 1e-1, 3)
    si = rng.uniform(1e-5, 1e-3, 3)
    bias_hat = gtsam.imuBias.ConstantBias(rng.normal(0, 0.1, 3), rng.normal(0, 0.01, 3))
    params = make_params(gravity_up, g, sg, sa, si)
    samples = [(float(dts[k]), vec(gyro[k]), vec(accel[k])) for k in range(n)]

    pim = integrate(gtsam.PreintegratedImuMeasurementsManifold, params, bias_hat, samples)
    tangent = integrate(gtsam.PreintegratedImuMeasurements, params, bias_hat, samples)

    # a prediction from a random state with a bias away from the estimate
    r_i = gtsam.Rot3.Expmap(rng.normal(0, 1, 3))
    p_i, v_i = rng.normal(0, 5, 3), rng.normal(0, 2, 3)
    bias_i = gtsam.imuBias.ConstantBias(
        np.asarray(bias_hat.accelerometer()) + rng.normal(0, 0.02, 3),
        np.asarray(bias_hat.gyroscope()) + rng.normal(0, 0.002, 3))
    state_j = pim.predict(gtsam.NavState(r_i, p_i, v_i), bias_i)

    return {
        "name": name,
        "gravity": vec(params.n_gravity),
        "gyro_sigma": vec(sg), "accel_sigma": vec(sa), "integration_sigma": vec(si),
        "bias_hat": {"gyro": vec(bias_hat.gyroscope()), "accel": vec(bias_hat.accelerometer())},
        "samples": [{"dt": d, "gyro": w, "accel": a} for d, w, a in samples],
        "delta_t": pim.deltaTij(),
        "delta_R": mat(pim.deltaRij().matrix()),
        "delta_p": vec(pim.deltaPij()),
        "delta_v": vec(pim.deltaVij()),
        "cov_gtsam": mat(pim.preintMeasCov()),
        "bias_jacobians": bias_jacobians(pim, bias_hat),
        "predict": {
            "R_i": mat(r_i.matrix()), "p_i": vec(p_i), "v_i": vec(v_i),
            "bias_i": {"gyro": vec(bias_i.gyroscope()), "accel": vec(bias_i.accelerometer())},
            "R_j": mat(state_j.attitude().matrix()),
            "p_j": vec(state_j.position()), "v_j": vec(state_j.velocity()),
        },
        "tangent_default_class": {
            "delta_R": mat(tangent.deltaRij().matrix()),
            "delta_p": vec(tangent.deltaPij()), "delta_v": vec(tangent.deltaVij()),
        },
    }


def main():
    rng = np.random.default_rng(SEED)
    cases = [
        case(rng, "slow, 200 samples at 200 Hz, z up", 200, (0.005, 0.005), 0.3, 0.5, True),
        case(rng, "fast turns, 400 samples, jittered dt, z up", 400, (0.002, 0.008), 2.0, 3.0, True),
        case(rng, "spin past pi about z, 300 samples, z down (NED)", 300, (0.01, 0.01), 0.5, 1.0,
             False, spin=[0.0, 0.0, 1.2]),
        case(rng, "long, 1000 samples at 100 Hz, z up", 1000, (0.01, 0.01), 1.0, 2.0, True),
    ]
    doc = {
        "what": "GTSAM PreintegratedImuMeasurementsManifold reference values (Forster et al. 2017)",
        "generator": "docs/lie/gtsam_preintegration.py",
        "command": "/tmp/gtsam-venv/bin/python docs/lie/gtsam_preintegration.py",
        "gtsam_version": version("gtsam"),
        "numpy_version": np.__version__,
        "python_version": sys.version.split()[0],
        "seed": SEED,
        "conventions": {
            "samples": "each (gyro, accel) held constant over its dt; bias_hat subtracted",
            "cov_gtsam": "GTSAM order and frame [dtheta, dp_body, dv_body] with dp_body = dRij^T dp",
            "bias_jacobians": "dR_dbg = d Log(dRij^T dRij(b)) / d bg; dp, dv additive in frame i",
            "matrices": "row-major lists of rows",
        },
        "cases": cases,
    }
    with open(OUT, "w") as f:
        json.dump(doc, f, indent=1)
        f.write("\n")
    print(f"wrote {OUT}: {len(cases)} cases, gtsam {version('gtsam')}")


if __name__ == "__main__":
    main()
