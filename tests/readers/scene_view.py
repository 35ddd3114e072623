#!/usr/bin/env python3
"""What the layout's 3D panel shows of each logged scene, computed from the log alone.

  python3 scene_view.py --layout docs/foxglove-layout.json [--panel-png PNG | --canvas W H] LOG...

An independent reader (the `mcap` package and the standard library, none of handover's code).
For every presented query of each log it takes the latest `/tf`, `/human/arm` and
`/scene/object` messages, places every point of the scene in the display frame and projects
it through the layout's camera as Lichtblick's 3D panel places its perspective camera
(CameraStateSettings: spherical (distance, phi, −thetaOffset) about `targetOffset` in the
`followTf` frame, rotated a quarter turn about x; orientation Euler(phi, 0, theta, "ZYX");
`fovy` vertical; the canvas's aspect). It checks:

- **framing**: every point of the body (shoulders, spine, the whole head box), the arm drawn
  and the object's grips and labels lies inside the canvas with a margin (`--margin`, a
  fraction of the half-width and half-height);
- **no stale arm**: the arm shown with a query is the one of its own grasp or none (an arm
  left from the trial before is reported);
- **labels clear**: no grip label's box on the canvas (7.6 px a character, 14 px high, centred
  on its point, as the layout's 13 px labels draw) overlaps another label or the pose arrow
  (`/robot/handover_pose`, drawn from the object's centre along its x axis, as long as the
  layout's `arrowScale` says) or the object's axes;
- **grip sides**: each grip's label is the protocol's label as the participant has it (for a
  left hand, whose poses are mirrored, "left" and "right" swapped), and of two offered grips
  whose labels name sides, the one named left lies on the participant's left (+y of the world
  frame, at least 2 cm apart) of the one named right.

The canvas is the 3D panel's screenshot less its 30-pixel title bar (`--panel-png`, as
check_log.py writes it), or given in pixels. One line per log, then `FAIL …` lines; exit 1 on any
failure, 2 on bad input.

Needs: pip install mcap
"""
import argparse
import json
import math
import re
import struct
import sys

try:
    from mcap.reader import make_reader
except ImportError as e:  # pragma: no cover
    sys.exit(f"scene_view.py: {e}; pip install mcap")

TITLE_BAR_PX = 30
CHAR_PX, LINE_PX = 7.6, 14.0


def quat_mul(a, b):
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    )


def rotate(q, v):
    x, y, z, w = q
    p = quat_mul(quat_mul(q, (v[0], v[1], v[2], 0.0)), (-x, -y, -z, w))
    return p[:3]


class Pose:
    """A rigid transform: p ↦ R p + t."""

    def __init__(self, t=(0.0, 0.0, 0.0), q=(0.0, 0.0, 0.0, 1.0)):
        n = math.sqrt(sum(c * c for c in q))
        self.t, self.q = tuple(t), tuple(c / n for c in q)

    @staticmethod
    def of(position, orientation):
        return Pose((position["x"], position["y"], position["z"]),
                    (orientation["x"], orientation["y"], orientation["z"], orientation["w"]))

    def apply(self, p):
        r = rotate(self.q, p)
        return (r[0] + self.t[0], r[1] + self.t[1], r[2] + self.t[2])

    def then(self, inner):
        """self ∘ inner: first inner, then self."""
        return Pose(self.apply(inner.t), quat_mul(self.q, inner.q))

    def inverse(self):
        qi = (-self.q[0], -self.q[1], -self.q[2], self.q[3])
        t = rotate(qi, self.t)
        return Pose((-t[0], -t[1], -t[2]), qi)


def rot_x(a):
    return lambda v: (v[0], v[1] * math.cos(a) - v[2] * math.sin(a), v[1] * math.sin(a) + v[2] * math.cos(a))


def rot_z(a):
    return lambda v: (v[0] * math.cos(a) - v[1] * math.sin(a), v[0] * math.sin(a) + v[1] * math.cos(a), v[2])


class Camera:
    """Lichtblick's perspective camera for a layout's `cameraState`, in the display frame."""

    def __init__(self, state, aspect):
        r, phi, theta = state["distance"], math.radians(state["phi"]), -math.radians(state["thetaOffset"])
        # three.js Spherical(r, phi, theta): (r sinφ sinθ, r cosφ, r sinφ cosθ), then a quarter
        # turn about x: (x, y, z) ↦ (x, −z, y).
        s = (r * math.sin(phi) * math.sin(theta), r * math.cos(phi), r * math.sin(phi) * math.cos(theta))
        off = state["targetOffset"]
        self.position = (s[0] + off[0], -s[2] + off[1], s[1] + off[2])
        # Euler(phi, 0, theta, "ZYX"): R = Rz(θ) Rx(φ); the camera looks along its −z, up +y.
        self.rx, self.rz_inv = rot_x(-phi), rot_z(-theta)
        self.tan = math.tan(math.radians(state["fovy"]) / 2)
        self.aspect = aspect

    def ndc(self, p):
        """Normalised device coordinates (−1…1 across the canvas) of a display-frame point."""
        d = tuple(p[i] - self.position[i] for i in range(3))
        c = self.rx(self.rz_inv(d))
        depth = -c[2]
        if depth <= 1e-9:
            return (math.inf, math.inf)
        return (c[0] / (depth * self.tan * self.aspect), c[1] / (depth * self.tan))


def png_size(path):
    with open(path, "rb") as f:
        head = f.read(24)
    if head[:8] != b"\x89PNG\r\n\x1a\n":
        sys.exit(f"scene_view.py: {path}: not a PNG")
    return struct.unpack(">II", head[16:24])


def experienced(label, hand):
    if hand != "left":
        return label
    swap = {"left": "right", "right": "left", "Left": "Right", "Right": "Left", "LEFT": "RIGHT", "RIGHT": "LEFT"}
    return re.sub(r"\w+", lambda m: swap.get(m.group(0), m.group(0)), label)


def side_named(label):
    words = re.findall(r"\w+", label.lower())
    if "left" in words and "right" not in words:
        return "left"
    if "right" in words and "left" not in words:
        return "right"
    return None


def entity_points(entity):
    """Every point an entity draws, in its own frame: line points, cube corners, texts."""
    pts = []
    for line in entity.get("lines", []):
        pose = Pose.of(line["pose"]["position"], line["pose"]["orientation"])
        pts += [pose.apply((p["x"], p["y"], p["z"])) for p in line["points"]]
    for cube in entity.get("cubes", []):
        pose = Pose.of(cube["pose"]["position"], cube["pose"]["orientation"])
        sx, sy, sz = cube["size"]["x"] / 2, cube["size"]["y"] / 2, cube["size"]["z"] / 2
        pts += [pose.apply((a * sx, b * sy, c * sz)) for a in (-1, 1) for b in (-1, 1) for c in (-1, 1)]
    for text in entity.get("texts", []):
        p = text["pose"]["position"]
        pts.append((p["x"], p["y"], p["z"]))
    return pts


def read_log(path):
    """The log's embedded protocol and its messages on the scene's topics, in log time order."""
    topics = ["/tf", "/human/arm", "/scene/object", "/trial/query"]
    with open(path, "rb") as f:
        reader = make_reader(f)
        protocol = next((json.loads(a.data) for a in reader.iter_attachments() if a.name == "protocol.json"), None)
        f.seek(0)
        messages = [(c.topic, json.loads(m.data)) for _, c, m in reader.iter_messages(topics=topics,
                                                                                      log_time_order=True)]
    if protocol is None:
        sys.exit(f"scene_view.py: {path}: no protocol.json attachment")
    return protocol, messages


def segment_hits_box(a, b, box):
    """Whether the segment a–b meets the axis-aligned box (x0, y0, x1, y1), by sampling."""
    x0, y0, x1, y1 = box
    for i in range(101):
        x, y = a[0] + (b[0] - a[0]) * i / 100, a[1] + (b[1] - a[1]) * i / 100
        if x0 <= x <= x1 and y0 <= y <= y1:
            return True
    return False


def check_log(path, layout, canvas, margin, failures):
    panel = next(v for k, v in layout["configById"].items() if k.startswith("3D!"))
    width_px, height_px = canvas
    camera = Camera(panel["cameraState"], width_px / height_px)
    arrow_length = panel["topics"]["/robot/handover_pose"]["arrowScale"][0]

    def pixels(p):
        x, y = camera.ndc(p)
        return ((x + 1) / 2 * width_px, (1 - y) / 2 * height_px)

    display = panel["followTf"]
    protocol, messages = read_log(path)
    hand = protocol.get("arm", {}).get("side", "right")
    frames = {}  # child frame -> (parent frame, pose in the parent)
    entities = {}  # entity id -> the entity shown
    query = None  # (event index, query id, the protocol's labels of the grips offered)
    arm_of = None  # the query whose grasp drew the arm shown
    out = {"scenes": 0, "worst": 0.0, "sides": 0, "labels": 0, "queries": set()}

    def to_world(frame):
        pose = Pose()
        while frame != "world":
            if frame not in frames:
                return None
            parent, p = frames[frame]
            pose, frame = p.then(pose), parent
        return pose

    def to_display(frame):
        a, b = to_world(frame), to_world(display)
        return None if a is None or b is None else b.inverse().then(a)

    for topic, m in messages:
        if topic == "/tf":
            for t in m["transforms"]:
                frames[t["child_frame_id"]] = (t["parent_frame_id"], Pose.of(t["translation"], t["rotation"]))
            continue
        if topic == "/trial/query":
            query = (m["event_index"], m["query"], m["region_labels"])
            continue
        for d in m.get("deletions", []):
            entities.pop(d["id"], None)
        for e in m["entities"]:
            entities[e["id"]] = e
        if topic == "/human/arm" and any(e["id"] == "human_arm" for e in m["entities"]):
            arm_of = query
        if topic != "/scene/object" or query is None:
            continue
        # A presented query's scene is whole once its object is published.
        out["scenes"] += 1
        out["queries"].add(query[1])
        what = f"{path}: query {query[1]} (event {query[0]})"
        if "human_arm" in entities and arm_of != query:
            failures.append(f"{what}: the arm of an earlier grasp is still shown")
        for e in entities.values():
            t = to_display(e["frame_id"])
            if t is None:
                failures.append(f"{what}: entity {e['id']} in frame {e['frame_id']} is not connected to {display}")
                continue
            for p in entity_points(e):
                x, y = camera.ndc(t.apply(p))
                out["worst"] = max(out["worst"], abs(x), abs(y))
                if abs(x) > 1 - margin or abs(y) > 1 - margin:
                    failures.append(f"{what}: a point of {e['id']} is outside the 3D panel "
                                    f"(x {x:+.2f}, y {y:+.2f}; the canvas less its margin is ±{1 - margin:.2f})")
                    break
        obj = entities["object"]
        texts = [t["text"] for t in obj["texts"] if not t["text"].endswith("(not offered)")]
        expected = [experienced(label, hand) for label in query[2]]
        if sorted(texts) != sorted(expected):
            failures.append(f"{what}: grip labels {texts}; the participant has them as {expected}")
        # Labels against each other and against the pose arrow, in pixels.
        to_disp = to_display("object")
        boxes = []
        for t in obj["texts"]:
            p = t["pose"]["position"]
            cx, cy = pixels(to_disp.apply((p["x"], p["y"], p["z"])))
            half = len(t["text"]) * CHAR_PX / 2
            boxes.append((t["text"], (cx - half, cy - LINE_PX / 2, cx + half, cy + LINE_PX / 2)))
        origin = pixels(to_disp.apply((0.0, 0.0, 0.0)))
        arrows = [("the pose arrow", pixels(to_disp.apply((arrow_length, 0.0, 0.0))))]
        for arrow in obj.get("arrows", []):
            length = arrow["shaft_length"] + arrow["head_length"]
            tip = Pose.of(arrow["pose"]["position"], arrow["pose"]["orientation"]).apply((length, 0.0, 0.0))
            arrows.append(("an axis of the object", pixels(to_disp.apply(tip))))
        for i, (text, box) in enumerate(boxes):
            out["labels"] += 1
            for name, tip in arrows:
                if segment_hits_box(origin, tip, box):
                    failures.append(f"{what}: {name} crosses the label '{text}'")
            for other, b in boxes[i + 1:]:
                if box[0] < b[2] and b[0] < box[2] and box[1] < b[3] and b[1] < box[3]:
                    failures.append(f"{what}: the labels '{text}' and '{other}' overlap")
        # Each grip's box and its label are pushed in the same order.
        object_to_world = to_world("object")
        named = []
        for cube, text in zip(obj["cubes"], obj["texts"]):
            if text["text"].endswith("(not offered)"):
                continue
            c = cube["pose"]["position"]
            named.append((side_named(text["text"]), object_to_world.apply((c["x"], c["y"], c["z"]))[1], text["text"]))
        for sl, yl, tl in named:
            for sr, yr, tr in named:
                if sl == "left" and sr == "right" and abs(yl - yr) >= 0.02:
                    out["sides"] += 1
                    if yl < yr:
                        failures.append(f"{what}: '{tl}' (y {yl:+.3f} m) is to the participant's right of "
                                        f"'{tr}' (y {yr:+.3f} m)")
    body = protocol.get("arm", {}).get("body_height_m")
    return hand, body, out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--layout", required=True)
    ap.add_argument("--panel-png", help="the 3D panel's screenshot, as check_log.py writes it")
    ap.add_argument("--canvas", type=float, nargs=2, default=(881, 641), metavar=("W", "H"),
                    help="the canvas in pixels without a screenshot (default: check_log.py's)")
    ap.add_argument("--margin", type=float, default=0.02)
    ap.add_argument("logs", nargs="+")
    a = ap.parse_args()
    try:
        layout = json.load(open(a.layout))
    except (OSError, ValueError) as e:
        sys.exit(f"scene_view.py: {a.layout}: {e}")
    if a.panel_png:
        w, h = png_size(a.panel_png)
        canvas = (w, h - TITLE_BAR_PX)
    else:
        canvas = (a.canvas[0], a.canvas[1])
    failures = []
    total = {"scenes": 0, "queries": set(), "bodies": set()}
    for path in a.logs:
        hand, body, out = check_log(path, layout, canvas, a.margin, failures)
        total["scenes"] += out["scenes"]
        total["queries"] |= {(hand, q) for q in out["queries"]}
        total["bodies"].add((hand, body))
        print(f"{path}: {hand} hand, {body} m body: {out['scenes']} scenes, the furthest point at "
              f"{out['worst']:.2f} of the half-canvas, {out['labels']} labels clear, "
              f"{out['sides']} left/right grip pairs checked")
    print(f"scene_view: {len(a.logs)} logs, {len(total['bodies'])} hand × body combinations, "
          f"{total['scenes']} scenes, {len(total['queries'])} hand × query poses, {len(failures)} failures")
    for f in failures:
        print("FAIL", f)
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main()
