#!/usr/bin/env python3
"""Throws bad MAVLink at a running `kestrel run` over UDP loopback and checks it shrugged it off
(run in CI by tests/gcs_mavlink_sweep.rs).

Usage:
    .venv/bin/python scripts/mavlink_sweep.py --frames N --seed S [--target udp:127.0.0.1:PORT]
        [--rate HZ] [--time-limit S] [--system-id ID] [--pid PID] [--min-pace X]
    .venv/bin/python scripts/mavlink_sweep.py --check-run --report FILE.json --record FILE.mcap
        [--log KESTREL.log]

The first form is the sweep. `--target` is a vehicle port that answers whoever talks to it
(default udp:127.0.0.1:14580, the API port of the default graph); only 127.0.0.1 is ever a target.
Two sockets of our own talk to it, each a peer (a link) of its own: the fuzzer, which sends
`--frames` datagrams at most `--rate` per second (default 2500/s, some ten times what a busy
ground station sends: a flood, yet one the vehicle's 1 Hz heartbeat and telemetry can get
through, which heartbeats_during checks) and stops after `--time-limit` seconds (default twice
the nominal time plus 30 s), whichever comes first; and the
checker, a pymavlink ground station (system 255) sending GCS heartbeats at 1 Hz. The frames are a
function of `--seed` and the vehicle's parameter names (their SHA-256 is printed: two runs with
one seed against one configuration print one digest);
the classes, picked per datagram by weight:

    random_bytes   1..300 random bytes, a third starting with a MAVLink start byte
    v2             a valid-CRC MAVLink 2 frame, unsigned (zero-trimmed or not)
    v2_signed      the same, signed with a key of the sweep's own (the vehicle holds none)
    v1             a valid-CRC MAVLink 1 frame of a message id < 256 (base fields only)
    truncated      a valid frame (v1 or v2) cut short
    oversized      a valid-CRC frame whose payload is longer than its message's, or one datagram
                   of 2..30 frames, or (1 in 20) a 1..64 kB datagram of frames and garbage
    own_sysid      a frame claiming the vehicle's own system id: forged armed HEARTBEATs,
                   LOCAL_POSITION_NED of ±1e38, an arming COMMAND_LONG, any other message
    command_long   COMMAND_LONG of every MAV_CMD value in turn (and unknown ids), random and
    command_int    COMMAND_INT  extreme parameters, addressed to the vehicle
    known_param    PARAM_SET of a parameter the vehicle listed, to NaN, ±inf, ±3.4e38 or ±1e30

The message-carrying classes walk every message id of pymavlink's ardupilotmega dialect in turn;
each field is random, an extreme of its type (NaN, ±inf, ±max, zero, min, max, denormals,
unterminated strings) or, for enum fields, a valid value (so frames get past decoding into the
handlers); targets are mostly the vehicle or broadcast; fake senders are system 255 or random,
never the vehicle's id outside `own_sysid`.

What is left out, and why (the checks below say "never armed, no parameter changed": a frame
that a real ground station would send to do exactly that must be left out, or the checks would
fail on a vehicle doing its job). Kept to well-formed values the vehicle is entitled to obey:
* MAV_CMD_COMPONENT_ARM_DISARM (COMMAND_LONG or COMMAND_INT, in any class) with param1 == 1.0
  exactly, addressed to the vehicle (target system 0 or ours, component 0 or ours) from another
  system: the vehicle boots in a mode that needs no sticks and may arm on it (arming is the only
  way our commander starts the motors, `Command::Arm`). Its param1 is drawn again. Every other
  param1 is sent: NaN, ±inf, 0.5, 1.0000001, 2, 1e30 must all be refused (PX4 and ArduPilot
  accept exactly 0 and 1); so is param1 == 1.0 claiming the vehicle's own system id (such a frame
  must be dropped), and param1 == 1.0 addressed to another system.
* MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN with param1 == 1.0 exactly, addressed to the vehicle from
  another system: a disarmed vehicle obeys it and its process exits to be restarted (ArduCopter
  reboots too), so the checks would see the vehicle gone. Its param1 is drawn again; every other
  param1 must be refused.
* PARAM_SET of a listed name with a value in its range: the sweep does not know the ranges (MAVLink
  does not carry them), so a listed name is only ever set to a value no range can hold (NaN,
  ±inf) or none a real parameter holds (±3.4e38, ±1e30); setting one of those is a hole.
  Other PARAM_SETs carry random names, which match nothing.
Nothing else is left out: a mode change, DO_SET_HOME, MISSION_* uploads, DO_FENCE_ENABLE and
take-off are all sent; none can arm, and none may move a disarmed vehicle.

The checks, on what MAVLink reports (the checker counts a frame from the vehicle's system id as a
forged echo when its bytes are those of a frame the fuzzer sent claiming that id, as the router
forwards frames untouched):
    heartbeats_during   the vehicle's heartbeats kept coming: none missing by its own clock (one
                        per vehicle second, from time_boot_ms), no gap over 5 s of wall time (a
                        ground station's link-lost timeout)
    heartbeats_after    at least 3 in the 5 s after the sweep
    params_complete     PARAM_REQUEST_LIST after the sweep answered every index 0..count-1 (gaps
                        re-read by PARAM_REQUEST_READ, as a ground station does)
    params_unchanged    the full list after equals the one before, bit for bit
    never_armed         no HEARTBEAT with MAV_MODE_FLAG_SAFETY_ARMED from the vehicle's id, as a
                        ground station sees it (genuine and forged counted apart)
    own_sysid_dropped   no frame claiming the vehicle's id forwarded back
    process_up          with `--pid`: the process still exists after the sweep
    pace                with `--min-pace X`: vehicle seconds per wall second during the sweep ≥ X
                        (lockstep paced at --speedup 1 falls behind when the graph cannot keep up)
The last line is one JSON object: {"ok": bool, "checks": {NAME: {"pass": bool, ...}}, "sent":
{CLASS: {"datagrams", "frames", "bytes"}}, "vehicle": {...}, "evidence": {...}}; exit 0 when
every check passed, 1 otherwise.

The second form, after the vehicle has stopped (SIGTERM), checks what only the run's own files
hold:
    loop_400hz          `--report` (kestrel run --report): control period p50 = 2500 µs, p99 ≤
                        3750 µs (the loop's own overrun threshold), no overruns. Under the lockstep
                        clock these are on the graph clock and see only a skipped step; whether the
                        graph kept up with the wall clock is the sweep's pace (printed always,
                        checked with --min-pace)
    never_moved         `--record` (an MCAP whose `[record] topics` include `ground_truth`): the
                        simulator's true position stays within 0.1 m of where it started, and the
                        vehicle never crashed (SIM_STATE and LOCAL_POSITION_NED report the
                        estimate, not the truth)
    no_actor_failed     the same MCAP holds the `supervisor` topic and nothing on it: every actor
                        failure and restart is published there, and a panicking actor restarted
                        leaves the process up, so "the process is up" alone would not see it
and prints the link's own counters from `--log` (kestrel's stderr), which it logs only when it
stops: per link frames in/out, refused, dropped, thinned; hub-wide undecodable, unroutable,
unhandled; the UDP server's peer counters.
"""

import argparse
import hashlib
import json
import math
import os
import random
import re
import socket
import struct
import sys
import threading
import time
from collections import Counter, defaultdict, deque

os.environ["MAVLINK20"] = "1"
from pymavlink import mavutil  # noqa: E402
from pymavlink.dialects.v10 import ardupilotmega as dialect_v1  # noqa: E402
from pymavlink.dialects.v20 import ardupilotmega as dialect  # noqa: E402


VEHICLE_COMPONENT = 1
CHECKER_SYSTEM, CHECKER_COMPONENT = 255, 190
ARM_DISARM = dialect.MAV_CMD_COMPONENT_ARM_DISARM
REBOOT = dialect.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN
ARMED_FLAG = dialect.MAV_MODE_FLAG_SAFETY_ARMED
LOOP_PERIOD_US = 2500.0
MAX_HEARTBEAT_GAP_S = 5.0
AFTER_S = 5.0
TRUTH_TOLERANCE_M = 0.1

# Datagram classes and their weights (per 100).
CLASSES = [
    ("random_bytes", 8), ("v2", 20), ("v2_signed", 8), ("v1", 10), ("truncated", 6),
    ("oversized", 6), ("own_sysid", 8), ("command_long", 15), ("command_int", 15),
    ("known_param", 4),
]

F32_MAX = 3.4028234663852886e38
F32_EXTREMES = [math.nan, math.inf, -math.inf, F32_MAX, -F32_MAX, 1e30, -1e30, 0.0, -0.0, 1.0,
                -1.0, 0.5, 1.401298464324817e-45, 1.1754943508222875e-38]
F64_EXTREMES = F32_EXTREMES + [1.7976931348623157e308, -1.7976931348623157e308, 5e-324]
# Command parameters worth trying besides those: selectors, the force codes (disarm 21196,
# arm 2989), a float just above 1.
PARAM_EXTREMES = F32_EXTREMES + [2.0, 3.0, 4.0, -2.0, 100.0, 21196.0, 2989.0, 65535.0,
                                 1.0000001192092896]
KNOWN_PARAM_VALUES = [math.nan, math.inf, -math.inf, F32_MAX, -F32_MAX, 1e30, -1e30]

CODES = {"int8_t": "b", "uint8_t": "B", "int16_t": "h", "uint16_t": "H", "int32_t": "i",
         "uint32_t": "I", "int64_t": "q", "uint64_t": "Q", "float": "f", "double": "d",
         "char": "c"}
SIZES = {"b": 1, "B": 1, "h": 2, "H": 2, "i": 4, "I": 4, "q": 8, "Q": 8, "f": 4, "d": 8, "c": 1}
INT_RANGES = {code: ((-(1 << (8 * n - 1)), (1 << (8 * n - 1)) - 1) if code.islower()
                     else (0, (1 << (8 * n)) - 1))
              for code, n in SIZES.items() if code not in "fdc"}


def f32(x):
    """`x` as the float32 the wire carries."""
    return struct.unpack("<f", struct.pack("<f", x))[0]


def enum_values(name):
    return [v for v, e in dialect.enums.get(name, {}).items() if not e.name.endswith("ENUM_END")]


MAV_CMDS = sorted(enum_values("MAV_CMD"))
UNKNOWN_CMDS = [c for c in (0, 1, 2, 99, 12345, 33333, 49999, 60000, 65535) if c not in MAV_CMDS]


class Layout:
    """One message's wire layout: fields in wire order with their struct code, array length,
    enum and whether the enum is a bitmask."""

    def __init__(self, cls):
        self.id, self.name, self.crc_extra = cls.id, cls.msgname, cls.crc_extra
        types = dict(zip(cls.fieldnames, cls.fieldtypes))
        self.fields = [
            (name, CODES[types[name]], n, cls.fieldenums_by_name.get(name),
             cls.fielddisplays_by_name.get(name) == "bitmask")
            for name, n in zip(cls.ordered_fieldnames, cls.array_lengths)
        ]
        sizes = [SIZES[code] * max(n, 1) for _, code, n, _, _ in self.fields]
        self.length = sum(sizes)
        old = dialect_v1.mavlink_map.get(self.id)
        v1_fields = set(old.ordered_fieldnames) if old is not None and old.crc_extra == self.crc_extra \
            else None
        self.v1_length = self.length if v1_fields is None else sum(
            s for (name, *_), s in zip(self.fields, sizes) if name in v1_fields)


LAYOUTS = {i: Layout(c) for i, c in sorted(dialect.mavlink_map.items())}
ALL_IDS = sorted(LAYOUTS)
V1_IDS = [i for i in ALL_IDS if i < 256]
# Messages a payload can run past (MAVLink's length byte stops at 255).
SHORT_IDS = [i for i in ALL_IDS if LAYOUTS[i].length < 255]
COMMAND_LONG_ID, COMMAND_INT_ID = dialect.MAVLINK_MSG_ID_COMMAND_LONG, dialect.MAVLINK_MSG_ID_COMMAND_INT


def crc(header_and_payload, extra):
    c = dialect.x25crc(header_and_payload)
    c.accumulate(bytes([extra]))
    return c.crc


def frame_v2(layout, payload, sysid, compid, seq, trim=True, key=None, stamp=0):
    if trim:
        end = len(payload)
        while end > 1 and payload[end - 1] == 0:
            end -= 1
        payload = payload[:end]
    flags = dialect.MAVLINK_IFLAG_SIGNED if key is not None else 0
    msgid = layout.id
    header = struct.pack("<BBBBBBBHB", 0xFD, len(payload), flags, 0, seq & 0xFF, sysid, compid,
                         msgid & 0xFFFF, msgid >> 16)
    out = header + payload
    out += struct.pack("<H", crc(out[1:], layout.crc_extra))
    if key is not None:
        link_stamp = struct.pack("<BQ", 0, stamp)[:7]
        out += link_stamp + hashlib.sha256(key + out + link_stamp).digest()[:6]
    return out


def frame_v1(layout, payload, sysid, compid, seq):
    out = struct.pack("<BBBBBB", 0xFE, len(payload), seq & 0xFF, sysid, compid, layout.id) + payload
    return out + struct.pack("<H", crc(out[1:], layout.crc_extra))


class Generator:
    """The sweep's datagrams, a function of the seed (and of `known_params`, the names listed)."""

    def __init__(self, seed, vehicle_sysid):
        self.rng = random.Random(seed)
        self.vehicle = vehicle_sysid
        self.key = hashlib.sha256(b"kestrel mavlink sweep %d" % seed).digest()
        self.cursor = Counter()
        self.seq = 0
        self.known_params = []
        self.neutralised = Counter()
        self.classes = [c for c, _ in CLASSES]
        self.weights = [w for _, w in CLASSES]

    def next_id(self, name, ids):
        i = self.cursor[name]
        self.cursor[name] += 1
        return ids[i % len(ids)]

    # -- values -------------------------------------------------------------------------------

    def real(self, code, extremes=None):
        rng = self.rng
        r = rng.random()
        if r < 0.45:
            return rng.choice(extremes or (F64_EXTREMES if code == "d" else F32_EXTREMES))
        if r < 0.75:
            return rng.uniform(-1e4, 1e4)
        return struct.unpack("<" + code, rng.randbytes(SIZES[code]))[0]

    def integer(self, code, enum, bitmask):
        rng = self.rng
        lo, hi = INT_RANGES[code]
        if enum and rng.random() < 0.5:
            values = [v for v in enum_values(enum) if lo <= v <= hi]
            if values:
                if bitmask:
                    return sum({v for v in values if rng.random() < 0.3}) & hi
                return rng.choice(values)
        if rng.random() < 0.4:
            return rng.choice([v for v in (lo, hi, 0, 1, -1, hi - 1) if lo <= v <= hi])
        return rng.randint(lo, hi)

    def text(self, n):
        rng = self.rng
        r = rng.random()
        if r < 0.3:
            return bytes(rng.choice(b"ABCDEFGHIJKLMNOPQRSTUVWXYZ_0123456789") for _ in range(n))
        if r < 0.5:
            return b"\xff" * n
        if r < 0.6:
            return b"\x00" * n
        return rng.randbytes(n)

    def field(self, name, code, n, enum, bitmask):
        if code == "c":
            return self.text(max(n, 1))
        count = max(n, 1)
        if code in "fd":
            if n and self.rng.random() < 0.3:
                return struct.pack("<%d%s" % (count, code), *[self.real(code)] * count)
            return struct.pack("<%d%s" % (count, code), *[self.real(code) for _ in range(count)])
        if n and code == "B" and self.rng.random() < 0.5:
            return self.rng.randbytes(count)
        if name == "target_system":
            value = self.rng.choice([self.vehicle] * 3 + [0, self.rng.randrange(256)])
        elif name == "target_component":
            value = self.rng.choice([VEHICLE_COMPONENT] * 3 + [0, self.rng.randrange(256)])
        else:
            value = None
        values = [value if value is not None else self.integer(code, enum, bitmask) for _ in range(count)]
        return struct.pack("<%d%s" % (count, code), *values)

    def payload(self, layout, sender):
        """Random and extreme fields for `layout`; commands go through `command_payload`."""
        if layout.id in (COMMAND_LONG_ID, COMMAND_INT_ID):
            command = self.rng.choice(MAV_CMDS + UNKNOWN_CMDS)
            return self.command_payload(layout, command, sender)
        return b"".join(self.field(*f) for f in layout.fields)

    def command_payload(self, layout, command, sender):
        values = {}
        for name, code, n, enum, bitmask in layout.fields:
            if name == "command":
                values[name] = struct.pack("<H", command)
            elif name.startswith("param") or name == "z":
                values[name] = struct.pack("<f", self.real("f", PARAM_EXTREMES))
            elif name in ("x", "y") and self.rng.random() < 0.5:
                values[name] = struct.pack("<i", self.rng.choice(
                    [0, 1, -1, 2**31 - 1, -2**31, 67971000, 799017000, 900000000, -1800000000]))
            else:
                values[name] = self.field(name, code, n, enum, bitmask)
        target = (values["target_system"][0], values["target_component"][0])
        # The exclusions (see the module doc): a well-formed arm or reboot, for us, from someone else.
        while (command == ARM_DISARM and struct.unpack("<f", values["param1"])[0] == 1.0
               and target[0] in (0, self.vehicle) and target[1] in (0, VEHICLE_COMPONENT)
               and sender != self.vehicle):
            self.neutralised["arm_param1_exactly_1"] += 1
            values["param1"] = struct.pack("<f", self.real("f", PARAM_EXTREMES))
        while (command == REBOOT and struct.unpack("<f", values["param1"])[0] == 1.0
               and target[0] in (0, self.vehicle) and target[1] in (0, VEHICLE_COMPONENT)
               and sender != self.vehicle):
            self.neutralised["reboot_param1_exactly_1"] += 1
            values["param1"] = struct.pack("<f", self.real("f", PARAM_EXTREMES))
        return b"".join(values[name] for name, *_ in layout.fields)

    def sender(self):
        """A fake sender's system id: mostly a ground station's, never the vehicle's."""
        s = CHECKER_SYSTEM if self.rng.random() < 0.6 else self.rng.randrange(256)
        return s if s != self.vehicle else CHECKER_SYSTEM

    def valid_frame(self, cls, sysid=None, layout=None):
        """(bytes, msgid) of a valid-CRC frame of class `v2`, `v2_signed` or `v1`."""
        rng = self.rng
        sysid = self.sender() if sysid is None else sysid
        compid = rng.choice([CHECKER_COMPONENT, 0, 1, rng.randrange(256)])
        self.seq += 1
        if cls == "v1":
            layout = layout or LAYOUTS[self.next_id("v1", V1_IDS)]
            payload = self.payload(layout, sysid)[: layout.v1_length]
            return frame_v1(layout, payload, sysid, compid, self.seq), layout.id
        layout = layout or LAYOUTS[self.next_id(cls, ALL_IDS)]
        payload = self.payload(layout, sysid)
        key = self.key if cls == "v2_signed" else None
        return frame_v2(layout, payload, sysid, compid, self.seq, trim=rng.random() < 0.7, key=key,
                        stamp=self.seq), layout.id

    # -- datagrams ----------------------------------------------------------------------------

    def next(self):
        """(class, datagram, [(frame bytes, sysid, msgid) of each valid frame in it])."""
        cls = self.rng.choices(self.classes, self.weights)[0]
        if cls == "known_param" and not self.known_params:
            cls = "v2"
        rng = self.rng
        if cls == "random_bytes":
            data = rng.randbytes(rng.randint(1, 300))
            if rng.random() < 0.33:
                data = bytes([rng.choice([0xFD, 0xFE])]) + data
            return cls, data, []
        if cls in ("v2", "v2_signed", "v1"):
            data, msgid = self.valid_frame(cls)
            return cls, data, [(data, None, msgid)]
        if cls == "truncated":
            data, _ = self.valid_frame(rng.choice(["v1", "v2"]))
            return cls, data[: rng.randint(1, len(data) - 1)], []
        if cls == "oversized":
            return self.oversized()
        if cls == "own_sysid":
            data, msgid = self.own_sysid()
            return cls, data, [(data, self.vehicle, msgid)]
        if cls in ("command_long", "command_int"):
            layout = LAYOUTS[COMMAND_LONG_ID if cls == "command_long" else COMMAND_INT_ID]
            command = self.next_id(cls, MAV_CMDS + UNKNOWN_CMDS)
            sysid = self.sender()
            payload = self.command_payload(layout, command, sysid)
            self.seq += 1
            if rng.random() < 0.15:
                data = frame_v1(layout, payload[: layout.v1_length], sysid, CHECKER_COMPONENT, self.seq)
            else:
                data = frame_v2(layout, payload, sysid, CHECKER_COMPONENT, self.seq)
            return cls, data, [(data, sysid, layout.id)]
        # known_param
        layout = LAYOUTS[dialect.MAVLINK_MSG_ID_PARAM_SET]
        name = rng.choice(self.known_params).encode()[:16].ljust(16, b"\0")
        value = rng.choice(KNOWN_PARAM_VALUES)
        payload = struct.pack("<fBB16sB", value, self.vehicle, VEHICLE_COMPONENT, name,
                              rng.choice([dialect.MAV_PARAM_TYPE_REAL32, dialect.MAV_PARAM_TYPE_INT32]))
        self.seq += 1
        data = frame_v2(layout, payload, CHECKER_SYSTEM, CHECKER_COMPONENT, self.seq)
        return cls, data, [(data, CHECKER_SYSTEM, layout.id)]

    def oversized(self):
        rng = self.rng
        r = rng.random()
        if r < 0.05:
            frames, parts, size = [], [], rng.randint(1000, 64000)
            while sum(map(len, parts)) < size:
                if rng.random() < 0.5:
                    parts.append(rng.randbytes(rng.randint(1, 500)))
                else:
                    data, msgid = self.valid_frame(rng.choice(["v1", "v2"]))
                    parts.append(data)
                    frames.append((data, None, msgid))
            return "oversized", b"".join(parts)[:65000], frames
        if r < 0.5:
            frames = [self.valid_frame(rng.choice(["v1", "v2", "v2_signed"])) for _ in range(rng.randint(2, 30))]
            return "oversized", b"".join(d for d, _ in frames), [(d, None, m) for d, m in frames]
        # One frame whose payload runs past its message's length, with a valid CRC.
        layout = LAYOUTS[rng.choice(SHORT_IDS)]
        sysid = self.sender()
        payload = self.payload(layout, sysid)
        payload += rng.randbytes(rng.randint(len(payload) + 1, 255) - len(payload))
        self.seq += 1
        if layout.id < 256 and rng.random() < 0.3:
            data = frame_v1(layout, payload, sysid, CHECKER_COMPONENT, self.seq)
        else:
            data = frame_v2(layout, payload, sysid, CHECKER_COMPONENT, self.seq, trim=False)
        return "oversized", data, [(data, sysid, layout.id)]

    def own_sysid(self):
        """A frame claiming the vehicle's system id (never signed, so the bytes a ground station
        gets forwarded are exactly these)."""
        rng = self.rng
        r = rng.random()
        compid = VEHICLE_COMPONENT if rng.random() < 0.7 else rng.randrange(256)
        self.seq += 1
        if r < 0.4:
            layout = LAYOUTS[dialect.MAVLINK_MSG_ID_HEARTBEAT]
            payload = struct.pack("<IBBBBB", rng.randrange(32), dialect.MAV_TYPE_QUADROTOR,
                                  dialect.MAV_AUTOPILOT_ARDUPILOTMEGA,
                                  ARMED_FLAG | dialect.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
                                  dialect.MAV_STATE_ACTIVE, 3)
        elif r < 0.6:
            layout = LAYOUTS[dialect.MAVLINK_MSG_ID_LOCAL_POSITION_NED]
            payload = struct.pack("<I6f", rng.randrange(2**32),
                                  *[rng.choice([1e38, -1e38, math.nan, math.inf]) for _ in range(6)])
        elif r < 0.7:
            layout = LAYOUTS[COMMAND_LONG_ID]
            payload = struct.pack("<7fHBBB", 1.0, *[0.0] * 6, ARM_DISARM, self.vehicle, VEHICLE_COMPONENT, 0)
        else:
            layout = LAYOUTS[rng.choice(ALL_IDS)]
            payload = self.payload(layout, self.vehicle)
        if layout.id < 256 and rng.random() < 0.2:
            return frame_v1(layout, payload[: layout.v1_length], self.vehicle, compid, self.seq), layout.id
        return frame_v2(layout, payload, self.vehicle, compid, self.seq), layout.id


# -- the checker ------------------------------------------------------------------------------


# Payloads this short (bytes) can be forged identical to a genuine one by chance in 10^6 frames.
SHORT_PAYLOAD = 8


class Monitor:
    """The checker: a pymavlink ground station on its own socket, and what it saw."""

    def __init__(self, host, port, vehicle_sysid):
        self.conn = mavutil.mavlink_connection(
            f"udpout:{host}:{port}", source_system=CHECKER_SYSTEM, source_component=CHECKER_COMPONENT)
        self.conn.port.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 8 << 20)
        self.vehicle = vehicle_sysid
        self.forged = set()
        self.lock = threading.Lock()
        self.last_gcs_heartbeat = 0.0
        self.heartbeats = []  # wall times of genuine vehicle heartbeats
        self.boot_ms = []  # (wall, time_boot_ms) of genuine vehicle messages
        self.armed_genuine = 0
        self.armed_forged = 0
        self.forged_echoes = Counter()
        # A forged frame can be byte for byte one the vehicle sends itself (EXTENDED_SYS_STATE's
        # two bytes, a matching sequence number): then nobody, this checker included, can tell a
        # forwarded copy from the genuine one, and it carries nothing the vehicle did not say.
        # Short genuine payloads are kept to recognise those; they are counted, not failed.
        self.genuine_short = defaultdict(set)
        self.indistinguishable = Counter()
        self.first_armed = None
        self.modes = Counter()
        self.statustext = Counter()
        self.params = {}
        self.param_count = None
        self.sys_status = None
        self.bad_data = 0
        self.messages = Counter()

    def send_gcs_heartbeat(self):
        now = time.monotonic()
        if now - self.last_gcs_heartbeat >= 1.0:
            self.conn.mav.heartbeat_send(dialect.MAV_TYPE_GCS, dialect.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            self.last_gcs_heartbeat = now

    def pump(self, timeout):
        """Handles every message arriving within `timeout` seconds (and sends the GCS heartbeat)."""
        end = time.monotonic() + timeout
        while True:
            self.send_gcs_heartbeat()
            left = end - time.monotonic()
            msg = self.conn.recv_match(blocking=True, timeout=max(0.0, min(left, 0.2)))
            if msg is not None:
                self.observe(msg)
            elif left <= 0:
                return

    def observe(self, msg):
        kind = msg.get_type()
        if kind == "BAD_DATA":
            self.bad_data += 1
            return
        if msg.get_srcSystem() != self.vehicle:
            return
        with self.lock:
            forged = bytes(msg.get_msgbuf()) in self.forged
        payload = bytes(msg.get_payload())
        if forged and payload in self.genuine_short[kind]:
            self.indistinguishable[kind] += 1
            forged = False
        elif not forged and len(payload) <= SHORT_PAYLOAD:
            self.genuine_short[kind].add(payload)
        if forged:
            self.forged_echoes[kind] += 1
            if kind == "HEARTBEAT" and msg.base_mode & ARMED_FLAG:
                self.armed_forged += 1
            return
        if msg.get_srcComponent() != VEHICLE_COMPONENT:
            return
        now = time.monotonic()
        self.messages[kind] += 1
        boot_ms = getattr(msg, "time_boot_ms", None)
        if boot_ms is not None:
            self.boot_ms.append((now, boot_ms))
        if kind == "HEARTBEAT":
            self.heartbeats.append(now)
            self.modes[mavutil.mode_string_v10(msg)] += 1
            if msg.base_mode & ARMED_FLAG:
                self.armed_genuine += 1
                if self.first_armed is None:
                    self.first_armed = now
        elif kind == "STATUSTEXT":
            self.statustext[msg.text] += 1
        elif kind == "PARAM_VALUE" and msg.param_index != 65535:
            self.param_count = msg.param_count
            self.params[msg.param_index] = (msg.param_id, struct.pack("<f", msg.param_value).hex())
        elif kind == "SYS_STATUS":
            self.sys_status = msg

    def wait_heartbeat(self, timeout):
        end = time.monotonic() + timeout
        while not self.heartbeats and time.monotonic() < end:
            self.pump(0.2)
        return bool(self.heartbeats)

    def fetch_params(self, timeout=30.0):
        """The full list, by PARAM_REQUEST_LIST and PARAM_REQUEST_READ for every gap, as a ground
        station does: ({name: value bits}, count, missing indexes, re-reads)."""
        self.params, self.param_count = {}, None
        self.conn.mav.param_request_list_send(self.vehicle, VEHICLE_COMPONENT)
        end = time.monotonic() + timeout
        rereads, seen, quiet_since = 0, 0, time.monotonic()
        while time.monotonic() < end:
            self.pump(0.1)
            if self.param_count is not None and len(self.params) >= self.param_count:
                break
            if len(self.params) != seen:
                seen, quiet_since = len(self.params), time.monotonic()
            elif time.monotonic() - quiet_since > 1.0:
                if self.param_count is None:
                    self.conn.mav.param_request_list_send(self.vehicle, VEHICLE_COMPONENT)
                else:
                    for i in [i for i in range(self.param_count) if i not in self.params][:20]:
                        self.conn.mav.param_request_read_send(self.vehicle, VEHICLE_COMPONENT, b"", i)
                        rereads += 1
                quiet_since = time.monotonic()
        count = self.param_count or 0
        missing = [i for i in range(count) if i not in self.params]
        values = {name: bits for i, (name, bits) in self.params.items() if i < count}
        return values, count, missing, rereads


# -- the sweep --------------------------------------------------------------------------------


def parse_target(text):
    m = re.fullmatch(r"udp:([0-9.]+):(\d+)", text)
    if m is None or m.group(1) != "127.0.0.1" or not 0 < int(m.group(2)) < 65536:
        sys.exit(f"--target {text!r}: only udp:127.0.0.1:PORT is allowed")
    return m.group(1), int(m.group(2))


def check(passed, **detail):
    return {"pass": bool(passed), **detail}


class Fuzzer:
    """The fuzzer's socket: sends the generator's datagrams at the rate limit, and counts what
    the vehicle sends back to it (COMMAND_ACKs per command and result)."""

    def __init__(self, args, monitor):
        self.args, self.monitor = args, monitor
        self.target = parse_target(args.target)
        self.gen = Generator(args.seed, args.system_id)
        self.socket = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.socket.bind(("127.0.0.1", 0))
        self.socket.settimeout(0.2)
        self.replies, self.acks = Counter(), Counter()
        self.sent = {c: Counter() for c, _ in CLASSES}
        self.digest = hashlib.sha256()
        # Commands and forged frames sent lately (wall time, class, hex), for the evidence.
        self.recent = deque(maxlen=4096)
        self.armed_evidence = None
        self.send_errors = 0
        self.stopped_by = "frames"

    def drain_replies(self, stop):
        parser = dialect.MAVLink(None)
        parser.robust_parsing = True
        while not stop.is_set():
            try:
                data = self.socket.recv(65536)
            except OSError:  # the timeout included
                continue
            try:
                msgs = parser.parse_buffer(data) or []
            except Exception:  # noqa: BLE001 - a reply pymavlink cannot parse is only counted
                self.replies["unparsable"] += 1
                continue
            for m in msgs:
                if m.get_srcSystem() == self.args.system_id and m.get_srcComponent() == VEHICLE_COMPONENT:
                    self.replies[m.get_type()] += 1
                    if m.get_type() == "COMMAND_ACK":
                        self.acks[(m.command, m.result)] += 1

    def note_arming(self):
        if self.armed_evidence is None and self.monitor.first_armed is not None:
            self.armed_evidence = describe_arming(self.recent, self.monitor.first_armed, self.args.system_id)

    def send_all(self):
        """Sends `--frames` datagrams at most `--rate` a second, within `--time-limit`."""
        args, monitor = self.args, self.monitor
        t0 = time.monotonic()
        for i in range(args.frames):
            due, now = t0 + i / args.rate, time.monotonic()
            if now > t0 + args.time_limit:
                self.stopped_by = "time limit"
                break
            if due > now:
                time.sleep(due - now)
            cls, data, frames = self.gen.next()
            forged = [f for f, sysid, _ in frames if sysid == args.system_id]
            if forged:
                with monitor.lock:
                    monitor.forged.update(forged)
            self.digest.update(data)
            try:
                self.socket.sendto(data, self.target)
            except OSError:
                self.send_errors += 1
            counts = self.sent[cls]
            counts["datagrams"] += 1
            counts["frames"] += len(frames)
            counts["bytes"] += len(data)
            if cls in ("command_long", "command_int", "own_sysid"):
                self.recent.append((time.monotonic(), cls, data.hex()))
            self.note_arming()
            if i and i % 50000 == 0:
                print(f"  {i} sent, {time.monotonic() - t0:.1f} s", flush=True)
        return t0, time.monotonic()

    def summary(self, seconds, pace):
        return {"datagrams": sum(c["datagrams"] for c in self.sent.values()), "seconds": round(seconds, 2),
                "stopped_by": self.stopped_by, "seed": self.args.seed, "rate_limit_hz": self.args.rate,
                "sha256": self.digest.hexdigest(), "send_errors": self.send_errors,
                "pace_vehicle_s_per_wall_s": round(pace, 3), "excluded": dict(self.gen.neutralised)}


def sweep(args):
    host, port = parse_target(args.target)
    monitor = Monitor(host, port, args.system_id)
    started = time.monotonic()
    print(f"sweep: {args.frames} datagrams, seed {args.seed}, at most {args.rate:g}/s, "
          f"time limit {args.time_limit:g} s, target {host}:{port}", flush=True)
    if not monitor.wait_heartbeat(30.0):
        print(json.dumps({"ok": False, "failed": "no heartbeat from the vehicle in 30 s"}), flush=True)
        return 1
    before, before_count, before_missing, _ = monitor.fetch_params()
    print(f"before: {before_count} parameters ({len(before_missing)} never answered)", flush=True)

    fuzzer = Fuzzer(args, monitor)
    fuzzer.gen.known_params = sorted(before)
    stop = threading.Event()

    def watch():
        while not stop.is_set():
            monitor.pump(0.2)

    threads = [threading.Thread(target=fuzzer.drain_replies, args=(stop,), daemon=True),
               threading.Thread(target=watch, daemon=True)]
    for t in threads:
        t.start()
    t0, sweep_end = fuzzer.send_all()
    print(f"sent {sum(c['datagrams'] for c in fuzzer.sent.values())} datagrams in {sweep_end - t0:.1f} s "
          f"(stopped by {fuzzer.stopped_by}), sha256 {fuzzer.digest.hexdigest()[:16]}", flush=True)
    time.sleep(0.5)
    stop.set()
    for t in threads:
        t.join()
    fuzzer.note_arming()

    # After: heartbeats still coming, then the full list again.
    during_heartbeats = [t for t in monitor.heartbeats if t0 <= t <= sweep_end]
    boot_during = [(w, b) for w, b in monitor.boot_ms if t0 <= w <= sweep_end]
    monitor.pump(AFTER_S)
    after_heartbeats = [t for t in monitor.heartbeats if t > sweep_end + 0.5]
    after, after_count, after_missing, rereads = monitor.fetch_params()
    fuzzer.socket.close()

    gaps = [b - a for a, b in zip([t0] + during_heartbeats, during_heartbeats + [sweep_end])]
    vehicle_s = (boot_during[-1][1] - boot_during[0][1]) / 1000.0 if len(boot_during) > 1 else 0.0
    wall_s = boot_during[-1][0] - boot_during[0][0] if len(boot_during) > 1 else 0.0
    pace = vehicle_s / wall_s if wall_s > 0 else 0.0
    changed = sorted(n for n in set(before) | set(after) if before.get(n) != after.get(n))
    checks = {
        "heartbeats_during": check(
            max(gaps) <= MAX_HEARTBEAT_GAP_S and len(during_heartbeats) >= math.floor(vehicle_s) - 1,
            received=len(during_heartbeats), vehicle_s=round(vehicle_s, 2), max_gap_s=round(max(gaps), 2)),
        "heartbeats_after": check(len(after_heartbeats) >= 3, received=len(after_heartbeats),
                                  window_s=AFTER_S - 0.5),
        "params_complete": check(after_count > 0 and not after_missing, count=after_count,
                                 missing=after_missing[:20], rereads=rereads),
        "params_unchanged": check(before_count > 0 and not changed and before_count == after_count,
                                  before=before_count, after=after_count, changed=changed[:20]),
        "never_armed": check(monitor.armed_genuine == 0 and monitor.armed_forged == 0,
                             genuine_armed_heartbeats=monitor.armed_genuine,
                             forged_armed_heartbeats=monitor.armed_forged),
        "own_sysid_dropped": check(not monitor.forged_echoes, forwarded=sum(monitor.forged_echoes.values()),
                                   by_message=dict(monitor.forged_echoes.most_common(6)),
                                   identical_to_genuine=dict(monitor.indistinguishable)),
    }
    if args.pid:
        checks["process_up"] = check(alive(args.pid), pid=args.pid)
    if args.min_pace:
        checks["pace"] = check(pace >= args.min_pace, pace=round(pace, 3), min=args.min_pace)
    status = monitor.sys_status
    result = {
        "ok": all(c["pass"] for c in checks.values()),
        "checks": checks,
        "sweep": {**fuzzer.summary(sweep_end - t0, pace), "elapsed_s": round(time.monotonic() - started, 1)},
        "sent": {c: dict(n) for c, n in fuzzer.sent.items()},
        "vehicle": {
            "messages_to_checker": dict(monitor.messages.most_common(12)),
            "replies_to_fuzzer": dict(fuzzer.replies.most_common(12)),
            "acks": summarise_acks(fuzzer.acks),
            "modes_seen": dict(monitor.modes),
            "statustext": dict(monitor.statustext.most_common(15)),
            "sys_status": None if status is None else {
                "drop_rate_comm": status.drop_rate_comm, "errors_comm": status.errors_comm},
            "checker_bad_data": monitor.bad_data,
        },
        "evidence": {"first_armed": fuzzer.armed_evidence},
    }
    print(json.dumps(result), flush=True)
    return 0 if result["ok"] else 1


def alive(pid):
    """Whether process `pid` exists (signal 0 sends nothing)."""
    try:
        os.kill(pid, 0)
    except OSError:
        return False
    return True


def command_name(cmd):
    entry = dialect.enums["MAV_CMD"].get(cmd)
    return entry.name if entry is not None else str(cmd)


def summarise_acks(acks):
    """{command: {result: n}} for the commands something was ACCEPTED for, and totals."""
    accepted = {}
    totals = Counter()
    for (cmd, result), n in acks.items():
        name = dialect.enums["MAV_RESULT"].get(result)
        totals[name.name if name is not None else str(result)] += n
        if result == dialect.MAV_RESULT_ACCEPTED:
            accepted[command_name(cmd)] = n
    return {"totals": dict(totals), "accepted": accepted}


def describe_arming(recent, first_armed, vehicle):
    """The arming candidates sent in the 1.5 s before the first armed heartbeat (the vehicle
    sends one a second): MAV_CMD_COMPONENT_ARM_DISARM addressed to the vehicle from another
    system with a param1 other than 0, decoded."""
    parser = dialect.MAVLink(None)
    parser.robust_parsing = True
    out = []
    for t, cls, hexdata in recent:
        if not first_armed - 1.5 <= t <= first_armed:
            continue
        try:
            msgs = parser.parse_buffer(bytes.fromhex(hexdata)) or []
        except Exception:  # noqa: BLE001 - evidence only
            continue
        for m in msgs:
            if (getattr(m, "command", None) == ARM_DISARM and m.get_srcSystem() != vehicle
                    and m.target_system in (0, vehicle) and m.target_component in (0, VEHICLE_COMPONENT)
                    and m.param1 != 0.0):
                out.append({"message": m.get_type(), "class": cls, "sent_s_before": round(first_armed - t, 3),
                            "sysid": m.get_srcSystem(),
                            "params": [repr(getattr(m, f"param{k}")) for k in range(1, 5)]})
    return out[-8:]


# -- after the run ----------------------------------------------------------------------------


def check_run(args):
    checks = {}
    report = json.load(open(args.report))
    control = report.get("control") or {}
    checks["loop_400hz"] = check(
        bool(control) and abs(control["period_p50_us"] - LOOP_PERIOD_US) <= 0.02 * LOOP_PERIOD_US
        and control["period_p99_us"] <= 1.5 * LOOP_PERIOD_US and control["overruns"] == 0,
        **{k: control.get(k) for k in ("period_p50_us", "period_p99_us", "period_max_us", "overruns")})
    from mcap.reader import make_reader

    first, worst, samples, crashed, failures = None, 0.0, 0, False, []
    with open(args.record, "rb") as stream:
        reader = make_reader(stream)
        summary = reader.get_summary()
        recorded = {c.topic for c in summary.channels.values()} if summary is not None else set()
        for _, channel, message in reader.iter_messages(topics=["ground_truth", "supervisor"]):
            event = json.loads(message.data)
            if channel.topic == "supervisor":
                failures.append({k: event.get(k) for k in ("actor", "kind", "reason")})
                continue
            p = event["position_ned_m"]
            first = first or p
            worst = max(worst, math.dist(first, p))
            crashed |= event["crashed"]
            samples += 1
    checks["never_moved"] = check(samples > 0 and worst <= TRUTH_TOLERANCE_M and not crashed,
                                  source="ground_truth topic of the MCAP", samples=samples,
                                  max_displacement_m=round(worst, 4), crashed=crashed)
    checks["no_actor_failed"] = check("supervisor" in recorded and not failures,
                                      source="supervisor topic of the MCAP", recorded="supervisor" in recorded,
                                      events=len(failures), first=failures[:5])
    result = {"ok": all(c["pass"] for c in checks.values()), "checks": checks,
              "flight": report.get("flight"), "failsafes": report.get("failsafes")}
    if args.log:
        result["counters"] = link_counters(open(args.log, errors="replace").read())
    print(json.dumps(result), flush=True)
    return 0 if result["ok"] else 1


def link_counters(log):
    """The link's counters as it logs them on stop, and the graph's mailbox overflow warnings."""
    ansi = re.compile(r"\x1b\[[0-9;]*m")
    out = {"links": [], "hub": None, "udp_servers": [], "overflow_lines": 0}
    for line in map(lambda l: ansi.sub("", l), log.splitlines()):
        if "MAVLink link counters" in line:
            out["links"].append(line.split("MAVLink link counters", 1)[1].strip())
        elif "MAVLink hub counters" in line:
            out["hub"] = line.split("MAVLink hub counters", 1)[1].strip()
        elif "UDP server peer counters" in line:
            out["udp_servers"].append(line.split("UDP server peer counters", 1)[1].strip())
        elif "overflow" in line.lower():
            out["overflow_lines"] += 1
    return out


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--frames", type=int, default=100_000, help="datagrams to send")
    p.add_argument("--seed", type=int, default=14)
    p.add_argument("--target", default="udp:127.0.0.1:14580")
    p.add_argument("--rate", type=float, default=2500.0, help="datagrams per second, at most")
    p.add_argument("--time-limit", type=float, help="seconds of sending, at most")
    p.add_argument("--system-id", type=int, default=1, help="the vehicle's MAVLink system id")
    p.add_argument("--pid", type=int, help="the vehicle's process, checked to be alive afterwards")
    p.add_argument("--min-pace", type=float, help="vehicle seconds per wall second required during the sweep")
    p.add_argument("--check-run", action="store_true", help="check a stopped run's --report, --record, --log")
    p.add_argument("--report")
    p.add_argument("--record")
    p.add_argument("--log")
    args = p.parse_args()
    if args.check_run:
        if not (args.report and args.record):
            p.error("--check-run needs --report and --record")
        return check_run(args)
    if args.frames <= 0 or args.rate <= 0:
        p.error("--frames and --rate must be positive")
    if args.time_limit is None:
        args.time_limit = 2.0 * args.frames / args.rate + 30.0
    return sweep(args)


if __name__ == "__main__":
    sys.exit(main())
