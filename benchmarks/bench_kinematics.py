"""Panda tip FK and Jacobian through ``Robot`` vs raw Pinocchio calls, and ``fk_batch`` throughput.

Raw Pinocchio = the minimal calls producing the same answer:
``forwardKinematics + updateFramePlacement(...).homogeneous`` and
``computeFrameJacobian(..., LOCAL_WORLD_ALIGNED)``. Targets: Robot <= 1.5x raw;
``fk_batch`` >= 300k configurations/s on one core.

    python benchmarks/bench_kinematics.py [--out FILE.json]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import pinocchio as pin

from kinserve import robots

from _common import machine, per_call_seconds, write_json


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--out")
    ap.add_argument("--batch", type=int, default=100_000)
    args = ap.parse_args()

    robot = robots.load("panda")
    frame = "panda_link8"
    model, data = robot.model, robot.model.createData()
    fid = model.getFrameId(frame)
    qs = robot.random_q(0, n=64)
    it = iter(range(1 << 62))

    def next_q():
        return qs[next(it) & 63]

    q = qs[0]
    raw_fk = per_call_seconds(lambda: (pin.forwardKinematics(model, data, q),
                                       pin.updateFramePlacement(model, data, fid).homogeneous))
    ours_fk = per_call_seconds(lambda: robot.fk(q, frame))
    raw_j = per_call_seconds(lambda: pin.computeFrameJacobian(model, data, q, fid, pin.LOCAL_WORLD_ALIGNED))
    ours_j = per_call_seconds(lambda: robot.jacobian(q, frame))

    Q = robot.random_q(1, n=args.batch)
    robot.fk_batch(Q[:1000], frame)
    times = []
    for _ in range(5):
        t0 = time.perf_counter()
        robot.fk_batch(Q, frame)
        times.append(time.perf_counter() - t0)
    batch_rate = args.batch / min(times)
    # the same batch as a Python loop over raw Pinocchio, for reference
    t0 = time.perf_counter()
    out = np.empty((20000, 4, 4))
    for i in range(20000):
        pin.forwardKinematics(model, data, Q[i])
        out[i] = pin.updateFramePlacement(model, data, fid).homogeneous
    loop_rate = 20000 / (time.perf_counter() - t0)

    res = {
        "machine": machine(),
        "fk_us": {"robot": ours_fk * 1e6, "raw_pinocchio": raw_fk * 1e6, "ratio": ours_fk / raw_fk},
        "jacobian_us": {"robot": ours_j * 1e6, "raw_pinocchio": raw_j * 1e6, "ratio": ours_j / raw_j},
        "fk_batch_per_s": batch_rate,
        "raw_pinocchio_loop_per_s": loop_rate,
        "targets": {"ratio_max": 1.5, "fk_batch_min_per_s": 300_000},
    }
    print(f"machine: {res['machine']['cpu']} ({res['machine']['cores']} cores), "
          f"Python {res['machine']['python']}")
    print(f"{'':22}{'Robot':>10}{'raw pin':>10}{'ratio':>8}   target")
    print(f"{'fk (us)':22}{ours_fk*1e6:10.3f}{raw_fk*1e6:10.3f}{ours_fk/raw_fk:8.2f}   <= 1.5")
    print(f"{'jacobian (us)':22}{ours_j*1e6:10.3f}{raw_j*1e6:10.3f}{ours_j/raw_j:8.2f}   <= 1.5")
    print(f"fk_batch: {batch_rate:,.0f} configurations/s (raw Pinocchio Python loop: "
          f"{loop_rate:,.0f}/s)   target >= 300,000")
    write_json(args.out, res)


if __name__ == "__main__":
    main()
