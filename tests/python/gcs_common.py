"""A pymavlink ground station for the `kestrel run` integration tests (tests/gcs_pymavlink.rs).

Listens on an ephemeral UDP port on 127.0.0.1 (as QGroundControl listens on 14550) and prints
`PORT <n>` first so the test can point the vehicle's `udp_out` endpoint at it; with `GCS_SERIAL`
set to a serial device (and `GCS_BAUD`, default 57600) it talks over that instead, as a ground
station on a radio does, and prints `PORT 0`. Everything it
learns comes from telemetry; every key event is printed as one transcript line:

    <wall s since start>  t=<vehicle time_boot_ms as s>  <event>

The last line is one JSON object: `{"ok": true, ...}` and exit 0, or `{"failed": STEP, ...}`
and exit 1.
"""

import json
import math
import os
import sys
import time

from pymavlink import mavutil

mav = mavutil.mavlink
VEHICLE = (1, 1)
ACM_MODES = {name: number for number, name in mavutil.mode_mapping_acm.items()}


class Failed(Exception):
    def __init__(self, step, detail):
        super().__init__(f"{step}: {detail}")
        self.step = step
        self.detail = detail


def enum_name(enum, value):
    entry = mav.enums.get(enum, {}).get(value)
    return entry.name if entry is not None else str(value)


class Gcs:
    """One ground station: a UDP socket, a 10 Hz heartbeat and the vehicle's state as seen."""

    def __init__(self, deadline_s=50.0, heartbeat_period_s=0.1):
        serial = os.environ.get("GCS_SERIAL")
        if serial:
            # A radio's end of a serial link (a socat pseudo-terminal in the tests): no UDP port.
            baud = int(os.environ.get("GCS_BAUD", "57600"))
            self.conn = mavutil.mavlink_connection(
                serial, baud=baud, source_system=255, source_component=190)
            self.port = 0
        else:
            self.conn = mavutil.mavlink_connection(
                "udpin:127.0.0.1:0", source_system=255, source_component=190)
            self.port = self.conn.port.getsockname()[1]
        print("PORT", self.port, flush=True)
        self.t0 = time.monotonic()
        self.deadline = self.t0 + deadline_s
        # The vehicle's clock runs `--speedup` times faster than the wall clock, so heartbeats go
        # out at 10 Hz of wall time to stay well inside its 5 s (vehicle time) link timeout.
        self.heartbeat_period_s = heartbeat_period_s
        self.heartbeats_on = True
        self.last_heartbeat_sent = 0.0
        self.last_heartbeat_sent_boot_s = None
        self.results = {}
        # The vehicle as telemetry shows it.
        self.heartbeat = None
        self.mode = None
        self.armed = None
        self.system_status = None
        self.landed_state = None
        self.boot_s = None
        self.position = None
        self.rel_alt_m = None
        self.max_rel_alt_m = 0.0
        self.alt_marks = [1.0, 5.0, 9.5, 14.5]
        self.mission_current = None
        self.mission_currents = []
        self.reached = []
        self.statustexts = []
        self.modes_seen = []
        self.bad_data = 0
        self.home = None
        self.sensors_healthy = False
        # Called with every message from the vehicle after it is observed (a scenario's own
        # bookkeeping, such as pairing ATTITUDE with SIMSTATE).
        self.watchers = []

    # -- transcript ---------------------------------------------------------------------------

    def log(self, event):
        wall = time.monotonic() - self.t0
        sim = f"{self.boot_s:7.2f}s" if self.boot_s is not None else "   -   "
        print(f"{wall:6.2f}s  t={sim}  {event}", flush=True)

    def finish(self):
        print(json.dumps({"ok": True, "results": self.results}), flush=True)
        sys.exit(0)

    def fail(self, step, detail):
        self.log(f"FAILED {step}: {detail}")
        print(json.dumps({"failed": step, "detail": str(detail), "results": self.results}), flush=True)
        sys.exit(1)

    # -- receiving ----------------------------------------------------------------------------

    def from_vehicle(self, msg):
        return (msg.get_srcSystem(), msg.get_srcComponent()) == VEHICLE

    def observe(self, msg):
        """Tracks the vehicle's state and logs what changed."""
        kind = msg.get_type()
        if kind == "BAD_DATA":
            self.bad_data += 1
            return
        if not self.from_vehicle(msg):
            return
        for watch in self.watchers:
            watch(msg)
        boot_ms = getattr(msg, "time_boot_ms", None)
        if boot_ms is not None:
            self.boot_s = boot_ms / 1000.0
        if kind == "HEARTBEAT":
            self.heartbeat = msg
            mode = mavutil.mode_string_v10(msg)
            armed = bool(msg.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED)
            status = enum_name("MAV_STATE", msg.system_status)
            if (mode, armed, status) != (self.mode, self.armed, self.system_status):
                self.log(f"HEARTBEAT mode={mode} armed={armed} system_status={status}")
            if mode != self.mode:
                self.modes_seen.append(mode)
            self.mode, self.armed, self.system_status = mode, armed, status
        elif kind == "GLOBAL_POSITION_INT":
            self.position = (msg.lat / 1e7, msg.lon / 1e7)
            self.rel_alt_m = msg.relative_alt / 1000.0
            self.max_rel_alt_m = max(self.max_rel_alt_m, self.rel_alt_m)
            while self.alt_marks and self.rel_alt_m >= self.alt_marks[0]:
                mark = self.alt_marks.pop(0)
                self.log(f"GLOBAL_POSITION_INT relative_alt={self.rel_alt_m:.2f} m (passed {mark} m)")
        elif kind == "EXTENDED_SYS_STATE":
            landed = enum_name("MAV_LANDED_STATE", msg.landed_state)
            if landed != self.landed_state:
                self.log(f"EXTENDED_SYS_STATE landed_state={landed}")
            self.landed_state = landed
        elif kind == "MISSION_CURRENT":
            if msg.seq != self.mission_current:
                self.log(f"MISSION_CURRENT seq={msg.seq} total={msg.total} "
                         f"state={enum_name('MISSION_STATE', msg.mission_state)}")
                self.mission_currents.append(msg.seq)
            self.mission_current = msg.seq
        elif kind == "MISSION_ITEM_REACHED":
            self.reached.append(msg.seq)
            self.log(f"MISSION_ITEM_REACHED seq={msg.seq}")
        elif kind == "HOME_POSITION":
            if self.home is None:
                self.log(f"HOME_POSITION lat={msg.latitude / 1e7:.7f} lon={msg.longitude / 1e7:.7f} "
                         f"alt={msg.altitude / 1000:.2f} m")
            self.home = (msg.latitude / 1e7, msg.longitude / 1e7)
        elif kind == "SYS_STATUS":
            present = msg.onboard_control_sensors_present
            healthy = msg.onboard_control_sensors_health & present == present
            if healthy != self.sensors_healthy:
                self.log(f"SYS_STATUS sensors {'all healthy' if healthy else 'not all healthy'} "
                         f"(present 0x{present:x}, health 0x{msg.onboard_control_sensors_health:x})")
            self.sensors_healthy = healthy
        elif kind == "STATUSTEXT":
            text = msg.text
            self.statustexts.append(text)
            self.log(f"STATUSTEXT [{enum_name('MAV_SEVERITY', msg.severity)}] {text}")
        elif kind == "COMMAND_ACK":
            self.log(f"COMMAND_ACK {enum_name('MAV_CMD', msg.command)} "
                     f"{enum_name('MAV_RESULT', msg.result)}")

    def send_heartbeat_if_due(self):
        now = time.monotonic()
        if self.heartbeats_on and now - self.last_heartbeat_sent >= self.heartbeat_period_s:
            self.conn.mav.heartbeat_send(mav.MAV_TYPE_GCS, mav.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            self.last_heartbeat_sent = now
            self.last_heartbeat_sent_boot_s = self.boot_s

    def pump(self, cond, timeout_s, step):
        """Receives (and observes) everything until `cond(msg)` holds; raises Failed on timeout."""
        end = min(time.monotonic() + timeout_s, self.deadline)
        while time.monotonic() < end:
            self.send_heartbeat_if_due()
            msg = self.conn.recv_match(blocking=True, timeout=0.02)
            if msg is None:
                continue
            self.observe(msg)
            if msg.get_type() != "BAD_DATA" and cond(msg):
                return msg
        raise Failed(step, f"timed out after {timeout_s} s")

    def wait_type(self, kind, timeout_s, step, cond=lambda m: True):
        return self.pump(lambda m: m.get_type() == kind and self.from_vehicle(m) and cond(m),
                         timeout_s, step)

    def quiet(self, seconds):
        """Keeps receiving (and heartbeating) for `seconds` of wall time."""
        end = time.monotonic() + seconds
        try:
            self.pump(lambda m: False, max(0.0, end - time.monotonic()), "quiet")
        except Failed:
            pass

    # -- steps --------------------------------------------------------------------------------

    def identify(self, timeout_s=10.0, types=(mav.MAV_TYPE_QUADROTOR,)):
        """Waits for the vehicle's HEARTBEAT (past boot) and checks who it is: an ArduPilot
        vehicle of one of `types` (MAV_TYPE)."""
        hb = self.wait_type("HEARTBEAT", timeout_s, "heartbeat",
                            lambda m: m.system_status != mav.MAV_STATE_BOOT)
        self.conn.target_system, self.conn.target_component = VEHICLE
        vehicle = {
            "type": enum_name("MAV_TYPE", hb.type),
            "autopilot": enum_name("MAV_AUTOPILOT", hb.autopilot),
            "mode": mavutil.mode_string_v10(hb),
            "mavlink": self.conn.WIRE_PROTOCOL_VERSION,
        }
        self.log(f"identified vehicle {VEHICLE}: {vehicle}")
        if hb.type not in types or hb.autopilot != mav.MAV_AUTOPILOT_ARDUPILOTMEGA:
            raise Failed("identify", vehicle)
        if vehicle["mode"] not in ACM_MODES:
            raise Failed("identify", f"mode {vehicle['mode']} has no ArduCopter name")
        self.results["vehicle"] = vehicle
        return hb

    def wait_ready(self, timeout_s=10.0):
        """What a ground station shows as ready to fly: every sensor healthy in SYS_STATUS (GPS
        included) and a HOME_POSITION."""
        self.pump(lambda m: self.sensors_healthy and self.home is not None, timeout_s, "ready")
        self.log("ready to fly: sensors healthy and home known")

    def command(self, cmd, params, step, expect=mav.MAV_RESULT_ACCEPTED, timeout_s=3.0):
        """COMMAND_LONG and its COMMAND_ACK; fails unless the result is `expect`."""
        p = list(params) + [0.0] * (7 - len(params))
        self.log(f"-> COMMAND_LONG {enum_name('MAV_CMD', cmd)} {p}")
        self.conn.mav.command_long_send(*VEHICLE, cmd, 0, *p)
        ack = self.wait_type("COMMAND_ACK", timeout_s, step, lambda m: m.command == cmd)
        if ack.result != expect:
            raise Failed(step, f"{enum_name('MAV_CMD', cmd)}: {enum_name('MAV_RESULT', ack.result)}")
        return ack

    def set_mode_message(self, name, step):
        """The legacy SET_MODE message (what MAVProxy's `mode` sends to older firmware)."""
        self.log(f"-> SET_MODE {name} (custom_mode {ACM_MODES[name]})")
        self.conn.mav.set_mode_send(VEHICLE[0], mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, ACM_MODES[name])
        ack = self.wait_type("COMMAND_ACK", 3.0, step, lambda m: m.command == mav.MAV_CMD_DO_SET_MODE)
        if ack.result != mav.MAV_RESULT_ACCEPTED:
            raise Failed(step, f"SET_MODE {name}: {enum_name('MAV_RESULT', ack.result)}")
        self.wait_type("HEARTBEAT", 3.0, step, lambda m: mavutil.mode_string_v10(m) == name)

    def set_mode_command(self, name, step):
        """MAV_CMD_DO_SET_MODE (what QGroundControl and current MAVProxy send)."""
        self.command(mav.MAV_CMD_DO_SET_MODE,
                     [mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, ACM_MODES[name]], step)
        self.wait_type("HEARTBEAT", 3.0, step, lambda m: mavutil.mode_string_v10(m) == name)

    def arm(self, step="arm"):
        self.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, [1], step)
        self.wait_type("HEARTBEAT", 3.0, step,
                       lambda m: m.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED)

    def fetch_params(self, timeout_s=5.0):
        """PARAM_REQUEST_LIST: every index 0..param_count-1 once; returns {name: value}."""
        t0 = time.monotonic()
        self.log("-> PARAM_REQUEST_LIST")
        self.conn.mav.param_request_list_send(*VEHICLE)
        by_index = {}

        def got_all(m):
            if m.get_type() != "PARAM_VALUE" or not self.from_vehicle(m):
                return False
            by_index[m.param_index] = (m.param_id, m.param_value, m.param_count)
            return len(by_index) == m.param_count

        self.pump(got_all, timeout_s, "param list")
        count = next(iter(by_index.values()))[2]
        if sorted(by_index) != list(range(count)):
            raise Failed("param list", f"indexes {sorted(by_index)} of {count}")
        params = {name: value for name, value, _ in by_index.values()}
        self.log(f"PARAM_VALUE x{count} in {time.monotonic() - t0:.3f} s: {params}")
        return params

    def set_param(self, name, value, step, expect_echo=None):
        """PARAM_SET; the PARAM_VALUE echo must carry `expect_echo` (default: `value`)."""
        echo = value if expect_echo is None else expect_echo
        self.log(f"-> PARAM_SET {name}={value}")
        self.conn.mav.param_set_send(*VEHICLE, name.encode(), value, mav.MAV_PARAM_TYPE_REAL32)
        m = self.wait_type("PARAM_VALUE", 3.0, step, lambda m: m.param_id == name)
        self.log(f"PARAM_VALUE {m.param_id}={m.param_value} (index {m.param_index}/{m.param_count})")
        if not math.isclose(m.param_value, echo, rel_tol=1e-6):
            raise Failed(step, f"{name} echoed {m.param_value}, wanted {echo}")
        return m

    def read_param(self, name, step):
        self.conn.mav.param_request_read_send(*VEHICLE, name.encode(), -1)
        m = self.wait_type("PARAM_VALUE", 3.0, step, lambda m: m.param_id == name)
        self.log(f"PARAM_VALUE (read by name) {m.param_id}={m.param_value}")
        return m.param_value


def plan_items(path):
    """The MISSION_ITEM_INT fields of a QGroundControl .plan, with home as item 0 (ArduPilot)."""
    with open(path) as f:
        plan = json.load(f)["mission"]
    home_lat, home_lon, home_alt = plan["plannedHomePosition"]
    items = [dict(command=mav.MAV_CMD_NAV_WAYPOINT, frame=mav.MAV_FRAME_GLOBAL,
                  params=[0.0, 0.0, 0.0, 0.0], lat=home_lat, lon=home_lon, alt=home_alt,
                  autocontinue=1)]
    for it in plan["items"]:
        if it["type"] != "SimpleItem":
            raise ValueError(f"only SimpleItems are supported, not {it['type']}")
        p = [math.nan if v is None else float(v) for v in it["params"]]
        items.append(dict(command=it["command"], frame=it["frame"], params=p[:4],
                          lat=p[4], lon=p[5], alt=p[6], autocontinue=int(it["autoContinue"])))
    for seq, item in enumerate(items):
        item["seq"] = seq
        item["x"] = int(round(item["lat"] * 1e7))
        item["y"] = int(round(item["lon"] * 1e7))
    return items


def same_float(a, b):
    return (math.isnan(a) and math.isnan(b)) or a == b


def item_int(command, frame, params=(0.0, 0.0, 0.0, 0.0), at=(0.0, 0.0), alt=0.0, autocontinue=1):
    """One plan item as `upload` sends it: MISSION_ITEM_INT's fields, `at` (latitude, longitude in
    degrees; (0, 0) for an item without a place) as 1e-7 degree."""
    lat, lon = at
    return dict(command=command, frame=frame, params=[float(p) for p in params],
                x=int(round(lat * 1e7)), y=int(round(lon * 1e7)), alt=float(alt),
                autocontinue=autocontinue)


def upload(gcs, items, step, mission_type=mav.MAV_MISSION_TYPE_MISSION, timeout_s=3.0,
           legacy_ok=True):
    """The mission protocol's upload of `items` (dicts with `item_int`'s keys) as `mission_type`:
    MISSION_COUNT, then the item each MISSION_REQUEST_INT asks for, as MISSION_ITEM_INT, until the
    MISSION_ACK; returns its result's name (`MAV_MISSION_ACCEPTED`, ...). A legacy MISSION_REQUEST
    is answered the same way, or fails the step without `legacy_ok`."""
    kind = enum_name("MAV_MISSION_TYPE", mission_type)
    gcs.log(f"-> MISSION_COUNT {len(items)} ({kind})")
    gcs.conn.mav.mission_count_send(*VEHICLE, len(items), mission_type)
    requested = []
    while True:
        m = gcs.pump(lambda m: gcs.from_vehicle(m)
                     and m.get_type() in ("MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK")
                     and m.mission_type == mission_type, timeout_s, step)
        if m.get_type() == "MISSION_ACK":
            result = enum_name("MAV_MISSION_RESULT", m.type)
            gcs.log(f"MISSION_ACK {result} ({step}) after requests for {requested}")
            return result
        if m.get_type() == "MISSION_REQUEST" and not legacy_ok:
            raise Failed(step, "the vehicle asked with legacy MISSION_REQUEST")
        if m.seq >= len(items):
            raise Failed(step, f"the vehicle asked for item {m.seq} of {len(items)}")
        requested.append(m.seq)
        it = items[m.seq]
        gcs.conn.mav.mission_item_int_send(
            *VEHICLE, m.seq, it["frame"], it["command"], 0, it["autocontinue"], *it["params"],
            it["x"], it["y"], it["alt"], mission_type)


def download(gcs, step, mission_type=mav.MAV_MISSION_TYPE_MISSION, timeout_s=3.0):
    """The mission protocol's download of `mission_type`: MISSION_REQUEST_LIST, each item by
    MISSION_REQUEST_INT, the closing MISSION_ACK; returns the MISSION_ITEM_INTs in order."""
    gcs.conn.mav.mission_request_list_send(*VEHICLE, mission_type)
    count = gcs.wait_type("MISSION_COUNT", timeout_s, step,
                          lambda m: m.mission_type == mission_type).count
    back = []
    for seq in range(count):
        gcs.conn.mav.mission_request_int_send(*VEHICLE, seq, mission_type)
        back.append(gcs.wait_type("MISSION_ITEM_INT", timeout_s, step,
                                  lambda m, s=seq: m.seq == s and m.mission_type == mission_type))
    gcs.conn.mav.mission_ack_send(*VEHICLE, mav.MAV_MISSION_ACCEPTED, mission_type)
    gcs.log(f"{step}: {count} items ({enum_name('MAV_MISSION_TYPE', mission_type)}), commands "
            f"{[b.command for b in back]}")
    return back


def upload_and_download(gcs, items):
    """Mission protocol both ways; fails unless the download equals the upload field by field."""
    t0 = time.monotonic()
    result = upload(gcs, items, "mission upload", legacy_ok=False)
    if result != "MAV_MISSION_ACCEPTED":
        raise Failed("mission upload", result)
    upload_s = time.monotonic() - t0

    t0 = time.monotonic()
    back = download(gcs, "mission download")
    download_s = time.monotonic() - t0
    count = len(back)
    if count != len(items):
        raise Failed("mission download", f"{count} items, uploaded {len(items)}")
    for it, b in zip(items, back):
        got = dict(command=b.command, frame=b.frame, autocontinue=b.autocontinue,
                   params=[b.param1, b.param2, b.param3, b.param4], x=b.x, y=b.y, alt=b.z)
        want = {k: it[k] for k in got}
        want["params"] = [float(mav_f32(v)) for v in it["params"]]
        want["alt"] = mav_f32(it["alt"])
        same = all(same_float(g, w) for g, w in zip(got["params"], want["params"])) and all(
            got[k] == want[k] for k in ("command", "frame", "autocontinue", "x", "y")) \
            and same_float(got["alt"], want["alt"])
        gcs.log(f"MISSION_ITEM_INT seq={b.seq} cmd={enum_name('MAV_CMD', b.command)} "
                f"frame={b.frame} x={b.x} y={b.y} z={b.z} params={got['params']}"
                + ("" if same else f"  != uploaded {want}"))
        if not same:
            raise Failed("mission download", f"item {b.seq} differs")
    gcs.log(f"downloaded {count} items identical in {download_s:.3f} s")
    return {"items": len(items), "upload_s": round(upload_s, 4), "download_s": round(download_s, 4),
            "downloaded_identical": True}


def mav_f32(v):
    """`v` as it survives a float32 field."""
    import struct
    return struct.unpack("<f", struct.pack("<f", v))[0]


def distance_m(a, b):
    """Flat-earth distance between two (lat, lon) in degrees (m)."""
    north = (a[0] - b[0]) * 111_320.0
    east = (a[1] - b[1]) * 111_320.0 * math.cos(math.radians(a[0]))
    return math.hypot(north, east)


def accepted(gcs, cmd, params, step):
    """COMMAND_LONG once; whether its COMMAND_ACK says ACCEPTED (no answer within 3 s: no)."""
    p = list(params) + [0.0] * (7 - len(params))
    gcs.conn.mav.command_long_send(*VEHICLE, cmd, 0, *p)
    try:
        ack = gcs.wait_type("COMMAND_ACK", 3.0, step, lambda m: m.command == cmd)
    except Failed:
        return False
    return ack.result == mav.MAV_RESULT_ACCEPTED


def arm_in_guided(gcs, timeout_s=40.0):
    """GUIDED, then armed, asked for every half second until the vehicle takes both: a vehicle
    refuses GUIDED or arming until its position estimate is good (ArduCopter: until EKF3 uses
    GPS, about 40 s of its time after boot, and it may leave GUIDED while it has no position),
    and an ACK lost on a loaded host is asked for again."""
    end = time.monotonic() + timeout_s
    guided = [mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, ACM_MODES["GUIDED"]]
    while not (gcs.mode == "GUIDED" and gcs.armed):
        if time.monotonic() > end:
            raise Failed("arm", f"still refused after {timeout_s} s: {gcs.statustexts[-3:]}")
        if gcs.mode != "GUIDED":
            accepted(gcs, mav.MAV_CMD_DO_SET_MODE, guided, "guided")
        elif accepted(gcs, mav.MAV_CMD_COMPONENT_ARM_DISARM, [1], "arm") or gcs.armed:
            try:
                gcs.wait_type("HEARTBEAT", 3.0, "arm", lambda m: m.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED)
            except Failed:
                pass
            continue
        gcs.quiet(0.5)


def main(body, deadline_s=50.0):
    """Runs `body(gcs)` and turns its outcome into the exit status and the last JSON line; the
    whole session must end within `deadline_s` of wall time."""
    gcs = Gcs(deadline_s=deadline_s)
    try:
        body(gcs)
    except Failed as e:
        gcs.fail(e.step, e.detail)
    gcs.finish()
