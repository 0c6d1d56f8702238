"""Read the Sinumerik and ABB RAPID programs back, independently of the writers (no open interpreter exists).

Each reader follows the controller's rules as the manuals state them, not the
writer's code:

* Sinumerik 840D (TRAORI on): X Y Z modal; A3 B3 C3 the tool's direction vector, a
  component left out of a block that writes another is zero, a block with none keeps
  the orientation; G0 / G1 and G93 / G94 modal; in G93 a G1 block takes 1 / F minutes
  and must carry its F; in G94 it takes length / F minutes; F is cleared when the
  feed type changes. Comments start with ``;``.
* RAPID: ``MoveL`` / ``MoveJ`` with a robtarget literal ``[[x,y,z],[q1,q2,q3,q4],...]``
  and a speeddata literal ``[v_tcp, v_ori, ...]`` (or a named one for MoveJ); a
  MoveL takes the longest of length / v_tcp and rotation / v_ori, s. The tool axis
  is minus the z axis of the quaternion's rotation matrix. Comments start with ``!``.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np


@dataclass
class OrientedMoves:
    ends: np.ndarray  # (K, 3) mm
    starts: np.ndarray  # (K, 3) mm
    axes: np.ndarray  # (K, 3) unit tool axes at the ends (tool tip to spindle)
    times: np.ndarray  # (K,) s (NaN: a rapid move)
    rapid: np.ndarray  # (K,) bool
    quats: np.ndarray | None = None  # (K, 4) RAPID orientations as written

    def runs(self) -> list[np.ndarray]:
        """Indices of each run of feed moves between rapid moves (one piece: approach, path, retract)."""
        idx = np.flatnonzero(~self.rapid)
        cuts = np.flatnonzero(np.diff(idx) > 1) + 1
        return np.split(idx, cuts) if len(idx) else []


def body(text: str, mark: str) -> list[str]:
    return [ln.strip() for ln in text.splitlines() if ln.strip() and not ln.strip().startswith(mark)]


# an address: one letter and its number (X-1.5, G93), or a name with '=' (A3=0.5)
_WORD = re.compile(r"(?:([A-Z][A-Z0-9]*)(=)|([A-Z]))([-+]?[0-9]*\.?[0-9]+)")


def trt_axis(kind: str, angles: dict) -> np.ndarray:
    """The tool axis in the part's frame of a table-tilting machine's rotary positions (degrees), as LinuxCNC's
    trt kinematics define them: xyzac-trt (sin A sin C, sin A cos C, cos A), xyzbc-trt (-cos C sin B, sin C sin B,
    cos B)."""
    c = np.radians(angles.get("C", 0.0))
    if kind == "xyzac-trt":
        a = np.radians(angles.get("A", 0.0))
        return np.array([np.sin(a) * np.sin(c), np.sin(a) * np.cos(c), np.cos(a)])
    b = np.radians(angles.get("B", 0.0))
    return np.array([-np.cos(c) * np.sin(b), np.sin(c) * np.sin(b), np.cos(b)])


def read_sinumerik(text: str, rotary: str | None = None) -> OrientedMoves:
    """The moves of a Sinumerik program; ``rotary``: the kinematics (``xyzac-trt``, ``xyzbc-trt``) of a program
    that writes the rotary axes' positions (A, B, C: modal, degrees) instead of A3/B3/C3."""
    ends, starts, axes, times, rapids = [], [], [], [], []
    pos, axis = np.full(3, np.nan), np.array([0.0, 0.0, 1.0])
    rot: dict = {}
    motion, inverse, feed = None, False, None
    for ln in body(text, ";"):
        words = {}
        for tok in ln.split():
            m = _WORD.fullmatch(tok)
            if m is None:
                continue
            name, eq, letter, val = m.groups()
            name = name or letter
            if name in ("A3", "B3", "C3") and eq != "=":
                raise AssertionError(f"{name} without '=' in {ln!r}")
            if name == "G":
                g = float(val)
                if g in (0, 1):
                    motion = int(g)
                elif g in (93, 94):
                    if (g == 93) != inverse:
                        feed = None  # the F value is cleared by a change of feed type
                    inverse = g == 93
                continue
            words[name] = float(val)
        if "F" in words:
            feed = words["F"]
        moved = any(a in words for a in "XYZ")
        turned = any(a in words for a in ("A3", "B3", "C3"))
        if rotary is not None:
            assert not turned, f"A3/B3/C3 in a program of rotary positions: {ln!r}"
            turned = any(a in words for a in "ABC")
        if not (moved or turned):
            continue
        new = np.array([words.get(a, pos[i]) for i, a in enumerate("XYZ")])
        if turned and rotary is not None:
            rot.update({a: words[a] for a in "ABC" if a in words})
            axis = trt_axis(rotary, rot)
        elif turned:
            v = np.array([words.get(a, 0.0) for a in ("A3", "B3", "C3")])
            axis = v / np.linalg.norm(v)
        if motion == 1:
            assert feed is not None and feed > 0, f"a feed move without F: {ln!r}"
            if inverse:
                assert "F" in words, f"G93 block without its F: {ln!r}"
                t = 60.0 / feed
            else:
                t = 60.0 * float(np.linalg.norm(new - pos)) / feed
        else:
            t = np.nan
        starts.append(pos.copy())
        ends.append(new)
        axes.append(axis.copy())
        times.append(t)
        rapids.append(motion == 0)
        pos = new
    return OrientedMoves(np.array(ends), np.array(starts), np.array(axes), np.array(times), np.array(rapids, bool))


def quat_matrix(q: np.ndarray) -> np.ndarray:
    """(K, 3, 3) rotation matrices of quaternions (K, 4), scalar first (normalised here)."""
    q = np.asarray(q, float)
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    w, x, y, z = q.T
    return np.stack([np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
                     np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
                     np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1)], 1)


def rotation_angles_deg(r0: np.ndarray, r1: np.ndarray) -> np.ndarray:
    """Angle, degrees, of the rotation from each matrix of ``r0`` (K, 3, 3) to ``r1``."""
    rel = np.einsum("kji,kjl->kil", r0, r1)
    c = np.clip((np.trace(rel, axis1=1, axis2=2) - 1) / 2, -1, 1)
    s = np.linalg.norm(np.stack([rel[:, 2, 1] - rel[:, 1, 2], rel[:, 0, 2] - rel[:, 2, 0],
                                 rel[:, 1, 0] - rel[:, 0, 1]], -1), axis=1) / 2
    return np.degrees(np.arctan2(s, c))


_MOVE = re.compile(r"(MoveL|MoveJ)\s*\[\[([^\]]*)\],\[([^\]]*)\],\[[^\]]*\],\[[^\]]*\]\]\s*,\s*"
                   r"(\[[^\]]*\]|[A-Za-z_][A-Za-z0-9_]*)\s*,\s*([A-Za-z_][A-Za-z0-9_]*)\s*,\s*"
                   r"([A-Za-z_][A-Za-z0-9_]*)\\WObj:=([A-Za-z_][A-Za-z0-9_]*);$")


def read_rapid(text: str) -> tuple[OrientedMoves, dict]:
    """The moves, and what else the module says: its name, the zonedata's values, the tool and work objects."""
    lines = body(text, "!")
    assert lines[0].startswith("MODULE ") and lines[-1] == "ENDMODULE", (lines[0], lines[-1])
    info = {"module": lines[0].split()[1], "tools": set(), "wobjs": set(), "zones": set()}
    ends, starts, quats, times, rapids = [], [], [], [], []
    pos, q = np.full(3, np.nan), None
    for ln in lines[1:-1]:
        if ln.startswith("CONST zonedata"):
            name, vals = re.match(r"CONST zonedata (\w+) := \[FALSE, ([^\]]*)\];", ln).groups()
            info["zonedata"] = (name, [float(v) for v in vals.split(",")])
            continue
        if not ln.startswith("Move"):
            continue
        m = _MOVE.match(ln)
        assert m is not None, ln
        kind, p, o, speed, zone, tool, wobj = m.groups()
        new = np.array([float(v) for v in p.split(",")])
        qn = np.array([float(v) for v in o.split(",")])
        assert abs(np.linalg.norm(qn) - 1) < 1e-5, f"quaternion not normalised: {ln!r}"
        info["tools"].add(tool)
        info["wobjs"].add(wobj)
        info["zones"].add(zone)
        if kind == "MoveL" and speed.startswith("["):
            v = [float(x) for x in speed.strip("[]").split(",")]
            length = float(np.linalg.norm(new - pos))
            ang = 0.0 if q is None else float(rotation_angles_deg(quat_matrix(q[None]), quat_matrix(qn[None]))[0])
            t = max(length / v[0], ang / v[1])
        else:
            t = np.nan
        starts.append(pos.copy())
        ends.append(new)
        quats.append(qn)
        times.append(t)
        rapids.append(kind == "MoveJ" or not speed.startswith("["))  # positioning: a joint move or a named speed
        pos, q = new, qn
    Q = np.array(quats)
    axes = -quat_matrix(Q)[:, :, 2]
    return OrientedMoves(np.array(ends), np.array(starts), axes, np.array(times), np.array(rapids, bool), Q), info
