"""cowork_robot kinematics against kinpy (PyPI) on the same URDF.

Usage: check_kinematics.py URDF DUMP.json [TOL]

DUMP.json comes from `cargo run -p cowork_robot --example fk_dump`. For every sample and every
link of the chain, kinpy's forward kinematics (position, rotation matrix) and kinpy's Jacobian
of the link origin (serial chain root -> link, rows linear then angular, base frame) are compared
with cowork's; so is the Jacobian of one random point on one random link (kinpy `calc_jacobian(..., tool=)`).
Prints the maximum errors; exits 1 if any exceeds TOL (default 1e-9).
"""

import json
import sys
from importlib.metadata import version

import numpy as np
import kinpy as kp
from kinpy.jacobian import calc_jacobian


def main() -> int:
    urdf_path, dump_path = sys.argv[1], sys.argv[2]
    tol = float(sys.argv[3]) if len(sys.argv) > 3 else 1e-9
    with open(urdf_path, "rb") as f:
        urdf = f.read().decode("utf-8")
    with open(dump_path) as f:
        dump = json.load(f)

    tip = dump["tip"]
    full = kp.build_serial_chain_from_urdf(urdf, tip)
    names = full.get_joint_parameter_names()
    if names != dump["joint_names"]:
        print(f"joint names differ: kinpy {names} cowork {dump['joint_names']}")
        return 1
    links = dump["link_names"]
    # One serial chain per link moved by a joint (kinpy's Jacobian is for the chain's end).
    moved = {name: e["joints"] for name, e in dump["samples"][0]["links"].items() if e["joints"] > 0}
    chains = {name: kp.build_serial_chain_from_urdf(urdf, name) for name in moved}

    err = {"position": 0.0, "rotation": 0.0, "jacobian": 0.0, "point_jacobian": 0.0}
    where = {k: "" for k in err}

    def note(kind: str, value: float, at: str) -> None:
        if value > err[kind]:
            err[kind] = value
            where[kind] = at

    for s, sample in enumerate(dump["samples"]):
        q = np.array(sample["q"])
        fk = full.forward_kinematics(q, end_only=False)
        for name in links:
            ours = sample["links"][name]
            theirs = fk[name].matrix()
            note("position", np.abs(theirs[:3, 3] - np.array(ours["position"])).max(), f"sample {s} {name}")
            note("rotation", np.abs(theirs[:3, :3] - np.array(ours["rotation"])).max(), f"sample {s} {name}")
            if name in chains:
                n = moved[name]
                j = np.zeros((6, 7))
                j[:, :n] = chains[name].jacobian(q[:n])
                note("jacobian", np.abs(j - np.array(ours["jacobian"])).max(), f"sample {s} {name}")
        pj = sample["point_jacobian"]
        n = pj["joints"]
        j = np.zeros((6, 7))
        if n > 0:
            tool = kp.Transform(pos=np.array(pj["point"]))
            j[:, :n] = calc_jacobian(chains[pj["link"]], q[:n], tool=tool)
        note("point_jacobian", np.abs(j - np.array(pj["jacobian"])).max(), f"sample {s} {pj['link']}")

    print(
        f"kinpy {version('kinpy')} vs cowork_robot on {urdf_path}: "
        f"{len(dump['samples'])} configurations, {len(links)} links ({', '.join(links)})"
    )
    ok = True
    for k, v in err.items():
        flag = "ok" if v <= tol else "MISMATCH"
        ok &= v <= tol
        print(f"  max |{k} error| = {v:.3e}  (tol {tol:.0e}, worst at {where[k] or '-'})  {flag}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
