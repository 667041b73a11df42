#!/usr/bin/python3
"""Write the small synthetic ddoc-hopper run directories used by tests/tools (deterministic).

    /usr/bin/python3 tools/testdata/make_testdata.py [OUT_DIR]   (default: this directory)

The motion is kinematic, not simulated: a ballistic flight with the leg swinging from -THETA0 to
+THETA0, then a stance phase pivoting about the fixed foot with the leg compressing by COMPRESSION.
It only has to look like hopping and follow the file formats. Known answers (asserted by the tests):

  exact_m8_alg1    12 hops, one rejected trial (hop 2), no push, converged_hop null in summary.json;
                   du2 + dT2 = 2.01 * 0.3**hop on accepted hops, so with eps 1e-3 and delta_i 3 the
                   convergence test holds first at hop 9 (2.01*0.3**7 = 4.4e-4 is the first below).
  inexact_m8_ocfb  falls in hop 4: hops.csv has 4 complete rows plus a cut-off 5th line without
                   newline, trajectory.csv also ends mid-line; summary fell=true, hops=4.
  push_m12_alg1    15 hops, push -20 N at t=3.0 s and +25 N at t=6.0 s (0.2 s each), converged_hop 11
                   given in summary.json.
"""
import json
import math
import os
import sys

G = 9.81
R0 = 0.7            # natural leg length [m]
THETA0 = 0.15       # leg angle at touchdown (+) and takeoff (-) [rad]
COMPRESSION = 0.08  # max leg compression in stance [m]
DT = 0.02           # sample period of trajectory.csv [s] (50 Hz keeps the files small)

HOPS_HEADER = ("hop,t_start,t_end,cost,I1,I2,I3,I4,T1,T2,step_length,speed,apex,alpha,accepted,"
               "du2,dT2,method")
TRAJ_HEADER = ("t,hop,phase,x,y,theta,phi,r,k_hip,k_leg,xd,yd,thetad,phid,rd,kd_hip,kd_leg,tau0,F0,"
               "k0_hip,k0_leg,push")
EVENTS_HEADER = "t,hop,type,x,y,xd,yd"


def fmt(*values):
    return ",".join(v if isinstance(v, str) else f"{v:.6g}" for v in values)


def hop_samples(t0, x0, v, t_flight, t_stance, phi_amp, push_at):
    """Samples of one hop starting at takeoff (t0, COM x0) with forward speed v.

    Returns (samples, touchdown sample, end state): samples are tuples in TRAJ_HEADER order (without
    hop); push_at(t) gives the push force at time t.
    """
    y0 = R0 * math.cos(THETA0)
    vy0 = G * t_flight / 2.0
    out = []
    n_f = max(int(round(t_flight / DT)), 1)
    n_s = max(int(round(t_stance / DT)), 1)
    for j in range(n_f):  # flight, leg swings forward
        s = j / n_f
        t = t0 + j * DT
        tf = j * DT
        x, y = x0 + v * tf, y0 + vy0 * tf - 0.5 * G * tf * tf
        th = -THETA0 + 2 * THETA0 * s
        phi = phi_amp * math.sin(2 * math.pi * s)
        out.append((t, 0, x, y, th, phi, R0, 60.0, 2000.0, v, vy0 - G * tf, 2 * THETA0 / t_flight,
                    0.0, 0.0, 0.0, 0.0, 0.5, 0.0, 60.0, 2000.0, push_at(t)))
    t_td = t0 + n_f * DT
    x_td = x0 + v * n_f * DT
    xf = x_td + R0 * math.sin(THETA0)
    td = (t_td, x_td, y0, v, -vy0)
    for j in range(n_s):  # stance, pivot about the foot at xf
        s = j / n_s
        t = t_td + j * DT
        th = THETA0 - 2 * THETA0 * s
        r = R0 - COMPRESSION * math.sin(math.pi * s)
        x, y = xf - r * math.sin(th), r * math.cos(th)
        rd = -COMPRESSION * math.pi / t_stance * math.cos(math.pi * s)
        thd = -2 * THETA0 / t_stance
        xd = -rd * math.sin(th) - r * thd * math.cos(th)
        yd = rd * math.cos(th) - r * thd * math.sin(th)
        out.append((t, 1, x, y, th, -0.3 * phi_amp, r, 60.0, 2000.0, xd, yd, thd, 0.0, rd, 0.0, 0.0,
                    0.2, -0.5, 60.0, 2100.0, push_at(t)))
    t_end = t_td + n_s * DT
    x_end = xf - R0 * math.sin(-THETA0)
    return out, td, (t_end, x_end)


def write_run(out_dir, name, scenario, method, n_hops, speeds, rejected=(), pushes=(),
              fall_in_hop=None, converged_hop=None):
    d = os.path.join(out_dir, name)
    os.makedirs(d, exist_ok=True)

    def push_at(t):
        return sum(f for (tp, f, dur) in pushes if tp <= t < tp + dur)

    hops, traj = [HOPS_HEADER], [TRAJ_HEADER]
    timed_events = [(tp, "push_start") for tp, _, _ in pushes] + \
                   [(tp + dur, "push_end") for tp, _, dur in pushes]
    events = [EVENTS_HEADER]
    t, x = 0.0, 0.0
    last_td = None
    summary_hops = n_hops
    all_samples = []
    for k in range(n_hops + (1 if fall_in_hop is not None else 0)):
        v = speeds(k)
        t_stance = 2 * R0 * math.sin(THETA0) / max(v, 0.2)
        t_flight = 0.30 + 0.02 * math.exp(-k / 3.0)
        if fall_in_hop is not None and k == fall_in_hop:
            # the fatal hop: the body pitches over and drops to the ground during flight
            for j in range(20):
                s = j / 19
                all_samples.append((k, (t + j * DT, 0, x + v * j * DT, 0.69 - 0.6 * s * s,
                                        -THETA0 - 0.8 * s, 1.4 * s, R0, 60.0, 2000.0, v,
                                        -2.5 * s, 0.0, 3.0, 0.0, 0.0, 0.0, 4.0, 0.0, 150.0, 2350.0,
                                        0.0)))
            t_fall = t + 19 * DT
            events.append(fmt(t_fall, k, "fall", x + v * 19 * DT, 0.09, v, -2.5))
            break
        samples, td, (t_end, x_end) = hop_samples(t, x, v, t_flight, t_stance, 0.04, push_at)
        all_samples += [(k, s) for s in samples]
        events.append(fmt(t, k, "takeoff", x, R0 * math.cos(THETA0), v, G * t_flight / 2))
        events.append(fmt(td[0], k, "touchdown", td[1], td[2], td[3], td[4]))
        foot = td[1] + R0 * math.sin(THETA0)
        step = foot - last_td if last_td is not None else x_end - x
        last_td = foot
        acc = 0 if k in rejected else 1
        du2 = 2.0 * 0.3 ** k if acc else 5.0
        dT2 = 0.01 * 0.3 ** k if acc else 0.02
        if k == 0:
            du2, dT2 = float("nan"), float("nan")  # no previous iteration to vary from
        cost = 0.4 + 3.0 * math.exp(-k / 2.5) + (0.8 if not acc else 0.0)
        i4 = 1e-3 * (0.05 * math.exp(-k / 2.0)) ** 2
        T2 = t_end - t
        apex = R0 * math.cos(THETA0) + G * t_flight ** 2 / 8
        hops.append(fmt(k, t, t_end, cost, 0.6 * cost, 0.3 * cost, 0.1 * cost - i4, i4, t_flight,
                        T2, step, (x_end - x) / T2, apex, 0.5 if not acc else 1.0, acc, du2, dT2,
                        method))
        t, x = t_end, x_end
    for tp, kind in timed_events:
        k, s = min(all_samples, key=lambda ks: abs(ks[1][0] - tp))  # nearest sample
        events.append(fmt(tp, k, kind, s[2], s[3], s[9], s[10]))
    traj += [fmt(s[0], k, *s[1:]) for k, s in all_samples]

    hops_text = "\n".join(hops) + "\n"
    traj_text = "\n".join(traj) + "\n"
    if fall_in_hop is not None:
        # the process died while writing: a cut-off hop row and a cut-off trajectory row
        summary_hops = fall_in_hop
        hops_text += fmt(fall_in_hop, t, t + 0.4, 9.5)[:14]
        traj_text += traj[-1][:25]
    with open(os.path.join(d, "hops.csv"), "w") as f:
        f.write(hops_text)
    with open(os.path.join(d, "trajectory.csv"), "w") as f:
        f.write(traj_text)
    with open(os.path.join(d, "events.csv"), "w") as f:
        f.write("\n".join(events) + "\n")
    summary = {"scenario": scenario, "method": method, "robot": "models/hopper_m8.xml",
               "hops": summary_hops, "fell": fall_in_hop is not None,
               "fall_reason": "body touched the ground" if fall_in_hop is not None else "",
               "converged_hop": converged_hop, "final_cost": None, "final_I4": None,
               "mean_speed": None, "mean_period": None, "wall_time_s": 1.0,
               "pushes": [{"t": tp, "force": f, "duration": dur} for tp, f, dur in pushes]}
    with open(os.path.join(d, "summary.json"), "w") as f:
        json.dump(summary, f, indent=1)
        f.write("\n")


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.dirname(os.path.abspath(__file__))
    write_run(out, "exact_m8_alg1", "exact_m8", "alg1", 12,
              lambda k: 0.9 - 0.3 * math.exp(-k / 3.0), rejected=(2,))
    write_run(out, "inexact_m8_ocfb", "inexact_m8", "ocfb", 4,
              lambda k: 0.7 + 0.15 * k, fall_in_hop=4)
    push_speed = (lambda k: 0.8 - (0.45 if k in (5, 6) else 0.0) + (0.5 if k in (10, 11) else 0.0))
    write_run(out, "push_m12_alg1", "push_m12", "alg1", 15, push_speed,
              pushes=((3.0, -20.0, 0.2), (6.0, 25.0, 0.2)), converged_hop=11)


if __name__ == "__main__":
    main()
