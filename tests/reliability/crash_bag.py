"""Crash consistency of `cowork bag record` under kill -9 (issue #19).

N times: starts lwr_sim (release binary, real-time rate, private domain) publishing
`/joint_states` at 1 kHz, `cowork bag record -o K.mcap /joint_states`, SIGKILL after a pseudo-random
1-8 s, and reads the file back the way every `cowork bag` command does (`cowork bag info --json`:
`BagReader::open_recoverable` + every message decoded and checked). Per kill it notes whether the
file is readable, how many messages it holds and how much of the stream before the kill is
missing (kill time minus the last message's log time, and that times the 1 kHz rate).

    python3 tests/reliability/crash_bag.py [--kills N] [--seed S] [--domain D]

Prints one row per kill and "N kills, C corrupt files, E empty, lost at most M messages (X s)"; exits
non-zero when a file was corrupt (unreadable, or a message that does not decode).
Standard library only; needs target/release/{lwr_sim,cowork}.
"""

import argparse
import json
import os
import random
import signal
import subprocess
import sys
import tempfile
import time

RATE_HZ = 1000.0  # lwr_sim's /joint_states rate (config/lwr_sim.yaml)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--kills", type=int, default=10)
    ap.add_argument("--seed", type=int, default=19)
    ap.add_argument("--domain", type=int, default=120 + os.getpid() % 80)
    ap.add_argument("--bin", default="target/release", help="folder of lwr_sim and cowork")
    ap.add_argument("--cowork", help="the cowork binary (default: BIN/cowork)")
    a = ap.parse_args()
    root = os.path.abspath(os.path.join(os.path.dirname(__file__), "../.."))
    binp = lambda n: os.path.join(root, a.cowork) if n == "cowork" and a.cowork else os.path.join(root, a.bin, n)  # noqa: E731
    env = dict(os.environ, ROS_DOMAIN_ID=str(a.domain))
    rnd = random.Random(a.seed)
    tmp = tempfile.mkdtemp(prefix="cowork-crash-bag-")
    rows = []
    sim = None

    def stop_sim():
        if sim is not None and sim.poll() is None:
            sim.send_signal(signal.SIGINT)
            try:
                sim.wait(timeout=5)
            except subprocess.TimeoutExpired:
                sim.kill()
                sim.wait()

    try:
        for k in range(a.kills):
            # A fresh lwr_sim per kill: the killed recorder's reliable reader stays matched
            # until its lease ends and makes lwr_sim's writes fail for every reader meanwhile
            # (tests/reliability/README.md), which would starve the next recorder.
            stop_sim()
            sim_log = open(os.path.join(tmp, f"lwr_sim{k}.log"), "wb")
            sim = subprocess.Popen([binp("lwr_sim"), "--rate", "1", "--duration", "3600"], cwd=root, env=env,
                                   stdout=sim_log, stderr=subprocess.STDOUT)
            time.sleep(1.5)
            out = os.path.join(tmp, f"kill{k}.mcap")
            log = open(os.path.join(tmp, f"record{k}.log"), "wb")
            rec = subprocess.Popen([binp("cowork"), "bag", "record", "-o", out, "/joint_states"], cwd=root, env=env,
                                   stdout=log, stderr=subprocess.STDOUT)
            t_start = time.time()
            time.sleep(rnd.uniform(1.0, 8.0))
            t_kill = time.time()
            rec.send_signal(signal.SIGKILL)
            rec.wait()
            size = os.path.getsize(out) if os.path.exists(out) else -1
            info = subprocess.run([binp("cowork"), "bag", "info", "--json", out], cwd=root, env=dict(env, RUST_BACKTRACE="0"),
                                  capture_output=True, text=True)
            readable, count, lost_s, bad, why = False, 0, float("nan"), 0, ""
            # `bag info` exits non-zero on a damaged (cut) file but still reports what it could
            # read; unreadable is no report at all.
            if info.stdout.strip().startswith("{"):
                try:
                    j = json.loads(info.stdout)
                    readable = True
                    count = int(j.get("message_count", 0))
                    end = j.get("end_ns")
                    # Nothing readable: everything since the recorder started is lost.
                    lost_s = t_kill - (end * 1e-9 if end else t_start)
                    bad = sum(int(c.get("bad", 0)) for c in j.get("checks", []))
                    # A file cut by the kill (no summary): read up to the cut, said here.
                    why = f"(damage: {j['damage'][:80]})" if j.get("damage") else "(complete)"
                except (ValueError, TypeError, AttributeError) as e:
                    why = f"unparsable info: {e}"
            else:
                why = (info.stderr.strip().splitlines() or ["?"])[0]
            rows.append((k, size, readable, count, bad, lost_s, why))
            print(f"kill {k}: {size:>8} bytes, readable {readable}, {count} messages, {bad} bad, "
                  f"{lost_s:.3f} s before the kill missing {why}", flush=True)
    finally:
        stop_sim()
    # A file killed before its header reached the disk (size <= 0) holds nothing and says so;
    # corrupt is a file with data that cannot be read, or a message that does not decode.
    corrupt = [r for r in rows if (r[1] > 0 and not r[2]) or r[4] > 0]
    empty = [r for r in rows if r[1] <= 0 or (r[2] and r[3] == 0)]  # nothing readable
    lost = max((r[5] for r in rows if r[2]), default=float("nan"))
    print(f"{len(rows)} kills, {len(corrupt)} corrupt files, {len(empty)} empty, lost at most "
          f"{lost * RATE_HZ:.0f} messages ({lost:.3f} s of /joint_states at {RATE_HZ:.0f} Hz)")
    for r in corrupt:
        print(f"CORRUPT kill {r[0]}: {r[6]}")
    return 1 if corrupt else 0


if __name__ == "__main__":
    sys.exit(main())
