"""A real ROS 2 peer of `reynoldsflow-ros2` (rclpy over Fast DDS), for
scripts/test-ros2 and scripts/bench-ros2.

    peer.py stream --segment JSON [--segment JSON ...] --received FILE --headers FILE ...
        Publish frames from raw files as sensor_msgs/Image, collect the node's
        outputs: their bytes back to back in FILE, one header line each
        ("SEC.NANOSEC FRAME_ID WxH ENCODING"), and the headers the node should
        have given (the pairing rules, written again here) in --expected.
    peer.py graph --expect TOPIC=TYPE ... | --absent TOPIC
        Whether the ROS graph shows (or, for some seconds, never shows) a topic.

Before the frames, an 8x8 warm-up stream runs until the node answers, so
both directions are matched (a best-effort sample sent before that is lost,
as DDS means it). Frames then go in lock-step: each waits for the outputs it
must give, and one that owes none (a stream's first) is followed after a
pause (`--window N` lets N frames be in flight, for the bench). Every
wait is bounded; a missing output fails the run rather than hanging it.
"""

import argparse
import json
import sys
import time

import rclpy
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import Image

ACCEPTED = {"mono8": 1, "rgb8": 3, "bgr8": 3, "rgba8": 4, "bgra8": 4}
WARM_UP = 8
# After a frame that owes no output, before the next (lock-step only).
PACE_S = 0.25


def log(line):
    print(f"peer: {line}", file=sys.stderr, flush=True)


def qos(reliable, depth=5):
    return QoSProfile(
        depth=depth,
        history=HistoryPolicy.KEEP_LAST,
        reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.VOLATILE,
    )


class Oracle:
    """The node's pairing rules (ros2/src/pairing.rs), written again: the
    headers each frame's outputs must carry."""

    def __init__(self, first_frame):
        self.mode = first_frame
        self.prev = None  # (width, height, encoding, stamp, header)
        self.awaits_copy = False

    def push(self, width, height, encoding, stamp, header):
        if encoding not in ACCEPTED:
            return []  # refused: logged and dropped, the stream goes on
        prev = self.prev
        self.prev = (width, height, encoding, stamp, header)
        if prev is None or prev[:3] != (width, height, encoding) or stamp < prev[3]:
            self.awaits_copy = self.mode == "repeat"
            return [header] if self.mode == "black" else []
        out = [prev[4]] if self.awaits_copy else []
        self.awaits_copy = False
        out.append(prev[4] if self.mode == "drop" else header)
        return out


class Peer:
    def __init__(self, args):
        self.node = rclpy.create_node("reynoldsflow_test_peer")
        self.outputs = []  # (header line, bytes) of the real frames
        self.warm = 0
        self.rosout = []
        self.pub = self.node.create_publisher(Image, args.input, qos(args.reliable))
        self.node.create_subscription(Image, args.output, self.on_image, qos(args.reliable))
        rosout_qos = QoSProfile(
            depth=100,
            history=HistoryPolicy.KEEP_LAST,
            reliability=ReliabilityPolicy.RELIABLE,
            durability=DurabilityPolicy.TRANSIENT_LOCAL,
        )
        try:
            from rcl_interfaces.msg import Log

            self.node.create_subscription(Log, "/rosout", lambda m: self.rosout.append(m.msg), rosout_qos)
        except ImportError:
            pass
        self.first_at = self.last_at = None

    def on_image(self, msg):
        if msg.width == WARM_UP and msg.height == WARM_UP:
            self.warm += 1
            return
        now = time.monotonic()
        self.first_at = self.first_at or now
        self.last_at = now
        h = msg.header
        line = f"{h.stamp.sec}.{h.stamp.nanosec:09d} {h.frame_id} {msg.width}x{msg.height} {msg.encoding} {msg.step}"
        self.outputs.append((line, msg.data.tobytes()))

    def spin_until(self, done, seconds):
        end = time.monotonic() + seconds
        while not done():
            if time.monotonic() > end:
                return False
            rclpy.spin_once(self.node, timeout_sec=0.01)
        return True

    def publish(self, width, height, encoding, step, data, sec, nanosec, frame_id):
        m = Image()
        m.header.stamp.sec, m.header.stamp.nanosec = sec, nanosec
        m.header.frame_id = frame_id
        m.width, m.height, m.encoding, m.step = width, height, encoding, step
        m.is_bigendian = 0
        m.data = data
        self.pub.publish(m)

    def warm_up(self, seconds):
        """8x8 mono8 frames until the node answers one."""
        end = time.monotonic() + seconds
        i = 0
        while self.warm == 0:
            if time.monotonic() > end:
                return False
            self.publish(WARM_UP, WARM_UP, "mono8", WARM_UP, bytes([i % 256]) * 64, 0, i, "warm_up")
            i += 1
            self.spin_until(lambda: self.warm > 0, 0.1)
        # Late answers to the warm-up are told apart by their size.
        self.spin_until(lambda: False, 0.3)
        return True


def frames_of(segment):
    """The segment's messages: (width, height, encoding, step, data, sec, nanosec, frame_id)."""
    width, height = (int(v) for v in segment["size"].split("x"))
    encoding = segment["encoding"]
    channels = ACCEPTED.get(encoding, int(segment.get("bytes_per_pixel", 2)))
    pad = int(segment.get("pad", 0))
    row = width * channels
    size = row * height
    start = int(segment.get("start_ns", 10**9))
    period = int(segment.get("period_ns", 33_333_333))
    frame_id = segment.get("frame_id", "camera")
    with open(segment["file"], "rb") as f:
        f.seek(size * int(segment.get("skip", 0)))
        for n in range(int(segment["frames"])):
            data = f.read(size)
            if len(data) < size:
                raise SystemExit(f"peer: {segment['file']}: frame {n} is short ({len(data)} of {size} bytes)")
            if pad:
                data = b"".join(data[y * row:(y + 1) * row] + bytes(pad) for y in range(height))
            t = start + n * period
            yield width, height, encoding, row + pad, data, t // 10**9, t % 10**9, frame_id


def stream(args):
    peer = Peer(args)
    if not peer.warm_up(args.timeout):
        log(f"no answer from the node on {args.output} to an {WARM_UP}x{WARM_UP} warm-up stream on {args.input} in {args.timeout} s")
        return 1
    oracle = Oracle(args.first_frame)
    expected = []
    pending = []  # outputs owed, per frame in flight
    sent = 0
    started = time.monotonic()
    for spec in args.segment:
        for (w, h, enc, step, data, sec, nsec, frame_id) in frames_of(json.loads(spec)):
            header = f"{sec}.{nsec:09d} {frame_id}"
            owed = oracle.push(w, h, enc, (sec, nsec), header)
            expected += [f"{line} {w}x{h} rgb8 {3 * w}" for line in owed]
            peer.publish(w, h, enc, step, data, sec, nsec, frame_id)
            sent += 1
            pending.append(len(expected))
            if not owed and args.window == 1:
                # Lock-step paces every frame that owes an output; one that
                # owes none (a stream's first frame) would be followed at
                # once by the next, and two 2.7 MB best-effort samples back
                # to back can overrun the node's socket buffer, losing the
                # second whole. Give the node the time to take it.
                peer.spin_until(lambda: False, PACE_S)
            # Lock-step (window 1), or up to --window frames in flight.
            while len(pending) >= args.window:
                want = pending.pop(0)
                if not peer.spin_until(lambda: len(peer.outputs) >= want, args.timeout):
                    log(f"after {sent} frames: {len(peer.outputs)} outputs, {want} expected (waited {args.timeout} s)")
                    return finish(args, peer, expected, sent, started, 1)
    for want in pending:
        if not peer.spin_until(lambda: len(peer.outputs) >= want, args.timeout):
            log(f"after {sent} frames: {len(peer.outputs)} outputs, {want} expected")
            return finish(args, peer, expected, sent, started, 1)
    # Anything beyond what is owed would be an extra output.
    peer.spin_until(lambda: len(peer.outputs) > len(expected), 0.5)
    return finish(args, peer, expected, sent, started, 0)


def finish(args, peer, expected, sent, started, code):
    with open(args.received, "wb") as f:
        for _, data in peer.outputs:
            f.write(data)
    with open(args.headers, "w") as f:
        f.writelines(line + "\n" for line, _ in peer.outputs)
    with open(args.expected, "w") as f:
        f.writelines(line + "\n" for line in expected)
    if args.rosout:
        with open(args.rosout, "w") as f:
            f.writelines(line + "\n" for line in peer.rosout)
    n = len(peer.outputs)
    if n > 1 and peer.last_at > peer.first_at:
        rate = (n - 1) / (peer.last_at - peer.first_at)
        log(f"{sent} frames sent, {n} outputs received in {time.monotonic() - started:.2f} s; {rate:.1f} outputs/s between the first and the last")
    else:
        log(f"{sent} frames sent, {n} outputs received")
    peer.node.destroy_node()
    return code


def graph(args):
    node = rclpy.create_node("reynoldsflow_graph_peer")

    def topics():
        return {name: types for name, types in node.get_topic_names_and_types()}

    end = time.monotonic() + args.timeout
    if args.absent:
        while time.monotonic() < end:
            rclpy.spin_once(node, timeout_sec=0.1)
            if args.absent in topics():
                log(f"{args.absent} is on the graph: {topics()[args.absent]}")
                return 1
        return 0
    want = dict(e.split("=", 1) for e in args.expect)
    while time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=0.1)
        seen = topics()
        if all(ty in seen.get(name, []) for name, ty in want.items()):
            for name in want:
                log(f"{name}: {', '.join(seen[name])}")
            return 0
    log(f"not on the graph after {args.timeout} s: {want}; seen {topics()}")
    return 1


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="command", required=True)
    s = sub.add_parser("stream")
    s.add_argument("--input", default="/image")
    s.add_argument("--output", default="/reynoldsflow/image")
    s.add_argument("--reliable", action="store_true")
    s.add_argument("--first-frame", default="drop", choices=["drop", "repeat", "black"])
    s.add_argument("--segment", action="append", required=True, help="JSON: file, size WxH, encoding, frames, [start_ns, period_ns, frame_id, pad, skip]")
    s.add_argument("--received", required=True)
    s.add_argument("--headers", required=True)
    s.add_argument("--expected", required=True)
    s.add_argument("--rosout", help="write the /rosout lines seen here")
    s.add_argument("--window", type=int, default=1)
    s.add_argument("--timeout", type=float, default=20.0)
    g = sub.add_parser("graph")
    g.add_argument("--expect", action="append", default=[])
    g.add_argument("--absent")
    g.add_argument("--timeout", type=float, default=10.0)
    args = p.parse_args()
    rclpy.init()
    try:
        return stream(args) if args.command == "stream" else graph(args)
    finally:
        rclpy.try_shutdown()


if __name__ == "__main__":
    sys.exit(main())
